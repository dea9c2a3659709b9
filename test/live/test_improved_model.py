"""The improved model: saved, loaded, and the live stepper equals the batch run."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from brake_hil.diagnosis.improved_model import ImprovedModel, read_improved_model
from brake_hil.errors import ImprovedModelError
from brake_hil.live.improved import load_improved_model
from brake_hil.physics.excitation import pulsing_profile
from test.conftest import CONFIG

MULTIPLIERS = {
    "caliper_stiffness": 0.9,
    "valve_resistance": 1.2,
    "effective_hydraulic_stiffness": 1.0,
    "effective_hydraulic_damping": 1.0,
    "bore_compliance": 1.1,
}


def _model(effects: tuple[str, ...], parameters: dict[str, float]) -> ImprovedModel:
    return ImprovedModel(
        rig_path=(CONFIG / "rig_default.yaml").resolve(),
        multipliers=MULTIPLIERS,
        effects=effects,
        parameters=parameters,
        flow_amplitude=3e-6,
        time_reference=3.0,
        pressure_ceiling=2.0e6,
    )


@pytest.mark.parametrize(
    ("effects", "parameters"),
    [
        ((), {}),
        (("seal_stick_slip",), {"seal_spring": 2.3e7, "slip_force": 250.0, "friction_share": 0.6}),
        (
            ("entrained_air", "sensor_delay"),
            {"air_share": 0.01, "delay_p_b": 0.0, "delay_F_k": 0.002, "delay_x_c": 0.0035},
        ),
        (
            ("hose_compliance", "orifice_flow"),
            {
                "hose_wall_ratio": 2.0,
                "hose_creep_ratio": 0.8,
                "hose_creep_time": 0.03,
                "turbulent_share": 0.5,
            },
        ),
        (
            ("seal_groove_asymmetry", "thermal_drift"),
            {
                "stiffness_asymmetry": 0.3,
                "relaxation_time": 1.0,
                "line_drift_rate": -0.01,
                "seal_drift_rate": -0.005,
            },
        ),
    ],
)
def test_live_stepper_equals_batch_after_a_round_trip(
    tmp_path: Path, effects: tuple[str, ...], parameters: dict[str, float]
) -> None:
    path = _model(effects, parameters).save(tmp_path / "improved_model.json")
    live = load_improved_model(path, mean_pressure=1.1e6)
    _, pressure = pulsing_profile((1.38e6,), ramp_s=0.5, pulsing_s=1.5)
    batch = live.batch(pressure)
    stepper = live.stepper()
    stepped = np.array([stepper.step(p) for p in pressure]).T
    scale = np.ptp(batch, axis=1)[:, None]
    assert np.max(np.abs(stepped - batch) / scale) < 1e-6


def test_malformed_files_are_refused_naming_the_file(tmp_path: Path) -> None:
    path = tmp_path / "bad.json"
    path.write_text("{not json")
    with pytest.raises(ImprovedModelError, match="bad.json: not valid JSON"):
        read_improved_model(path)
    document = _model(("seal_stick_slip",), {"seal_spring": 2.3e7}).as_dict()
    path.write_text(json.dumps(document))
    with pytest.raises(ImprovedModelError, match="missing parameter 'slip_force'"):
        read_improved_model(path)
    document["effects"] = ["warp_drive"]
    path.write_text(json.dumps(document))
    with pytest.raises(ImprovedModelError, match="unknown effect 'warp_drive'"):
        read_improved_model(path)


def test_an_older_hose_model_is_refused_and_the_creep_is_used(tmp_path: Path) -> None:
    """An older file holds ``hose_compliance_ratio``, a multiple of each
    segment's ``C_b``: run now it would mean another hose, so it is refused, naming the file
    and the value. A current file's creep changes the prediction (used, not ignored)."""
    _, pressure = pulsing_profile((1.38e6,), ramp_s=0.5, pulsing_s=1.5)
    older = _model(("hose_compliance",), {"hose_compliance_ratio": 2.0}).as_dict()
    path = tmp_path / "older.json"
    path.write_text(json.dumps(older))
    with pytest.raises(ImprovedModelError, match="older.json: 'hose_compliance_ratio' of hose"):
        read_improved_model(path)
    elastic = {"hose_wall_ratio": 2.0, "hose_creep_ratio": 0.0, "hose_creep_time": 0.03}
    stiff = load_improved_model(_model(("hose_compliance",), elastic).save(path), 1.1e6)
    creeping = {**elastic, "hose_creep_ratio": 1.0}
    newer = _model(("hose_compliance",), creeping).save(tmp_path / "newer.json")
    crept = load_improved_model(newer, mean_pressure=1.1e6).batch(pressure)
    unswollen = stiff.batch(pressure)
    assert np.max(np.abs(crept[0] - unswollen[0])) > 1e-3 * np.ptp(unswollen[0])


def test_an_older_eccentric_load_without_curvature_loads_as_the_linear_share_it_was(
    tmp_path: Path,
) -> None:
    """A file written while the caliper's share was linear in ``p_b`` reads with no
    curvature; a curvature, when there, changes the prediction."""
    _, pressure = pulsing_profile((1.38e6,), ramp_s=0.5, pulsing_s=1.5)
    linear = {"share_offset": -0.2, "share_slope": 0.05}
    path = tmp_path / "older.json"
    path.write_text(json.dumps(_model(("eccentric_load",), linear).as_dict()))
    assert read_improved_model(path).parameters["share_curvature"] == 0.0
    older = load_improved_model(path, mean_pressure=1.1e6).batch(pressure)
    curved = _model(("eccentric_load",), {**linear, "share_curvature": -0.05})
    newer = load_improved_model(curved.save(tmp_path / "newer.json"), mean_pressure=1.1e6)
    bent = newer.batch(pressure)
    assert np.max(np.abs(bent[2] - older[2])) > 1e-3 * np.ptp(older[2])  # x_c


def test_the_caliper_node_loader_reads_an_improved_model(tmp_path: Path) -> None:
    from brake_hil.live.model_file import load_model

    path = _model(("entrained_air",), {"air_share": 0.02}).save(tmp_path / "improved.json")
    live = load_model(path, 1.2e6)
    assert "entrained_air" in live.description
    stepper = live.stepper()
    first = stepper.step(1.2e6)
    assert first.bore_pressure == pytest.approx(1.2e6, rel=1e-9)
