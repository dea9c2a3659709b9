"""The diagnosis on excitations other than steady pulsing: windows per segment kind, the
noise where nothing repeats, and the bundled ramp and sweep diagnosed end to end."""

from __future__ import annotations

from pathlib import Path

import pytest

from brake_hil.app.diagnose import run_diagnose
from brake_hil.diagnosis.dataset import HELD_OUT_SHARE, Window, prepare, split
from brake_hil.io.opened import open_recording
from test.conftest import PROJECT

BAGS = PROJECT / "bags"


def _opened(name: str):  # type: ignore[no-untyped-def]
    return open_recording(BAGS / name, BAGS / f"{name}.rig.yaml")


def _inside(part: Window, whole: Window) -> bool:
    return whole.start - 1e-9 <= part.start < part.end <= whole.end + 1e-9


def test_each_kind_holds_out_its_later_part() -> None:
    pulsing = Window(0.0, 3.0, 1e6, 0, kind="pulsing", capped=False, period=0.1)
    sweep = Window(4.0, 14.0, 1e6, 1, kind="sweep", capped=False)
    rise = Window(15.0, 18.0, 1.4e6, 2, kind="ramp", capped=False)
    fall = Window(19.0, 22.0, 1.4e6, 3, kind="ramp", capped=False)
    train, held = split([pulsing, sweep, rise, fall])
    assert len(train) == len(held) == 4
    for whole, fitted, scored in zip((pulsing, sweep, rise, fall), train, held):
        assert _inside(fitted, whole) and _inside(scored, whole)
        assert fitted.end == pytest.approx(scored.start)  # later, never overlapping
        assert scored.end - scored.start == pytest.approx(
            HELD_OUT_SHARE * (whole.end - whole.start), abs=0.05
        )
    assert held[0].end - held[0].start == pytest.approx(1.2)  # 12 whole cycles of 0.1 s
    assert held[2].lead_in > 0.0  # a ramp's held part is simulated from before it
    steady = Window(0.0, 3.0, 1e6, 0, period=0.2)
    assert split([steady])[1][0].lead_in == 0.0  # steady pulsing keeps its 0.8 s preroll
    # two rises and two falls: the later pair is held out whole
    more = [rise, fall, Window(23, 26, 1.4e6, 4, "ramp"), Window(27, 30, 1.4e6, 5, "ramp")]
    train, held = split(more)
    assert [w.start for w in train] == [15.0, 19.0]
    assert [w.start for w in held] == [23, 27]


def test_a_ramp_recording_is_prepared_not_refused() -> None:
    opened = _opened("ramp_one_washer")
    ds = prepare(opened.recording, opened.rig)  # raised "No steady segment" before
    assert [w.kind for w in ds.segments] == ["ramp", "ramp"]
    assert all(w.kind == "ramp" for w in (*ds.train, *ds.held_out))
    for fitted, scored in zip(ds.train, ds.held_out):
        assert fitted.end <= scored.start + 1e-9
    assert 0.0 < ds.noise_cost() < 1e-4


def test_the_sweep_holds_out_the_band_it_ends_on() -> None:
    opened = _opened("sweep_one_washer")
    ds = prepare(opened.recording, opened.rig)
    (sweep,) = ds.segments
    assert sweep.kind == "sweep" and not sweep.capped
    assert ds.held_out[0].end == pytest.approx(sweep.end)
    assert ds.held_out[0].start == pytest.approx(
        sweep.start + (1 - HELD_OUT_SHARE) * (sweep.end - sweep.start)
    )


def test_the_noise_without_cycles_agrees_with_the_cycle_to_cycle_noise() -> None:
    """On steady pulsing both estimates exist: the one from the raw channels above 150 Hz
    (used where nothing repeats) is within 1.5 times the cycle-to-cycle one (4 % apart on
    three bundled recordings)."""
    from dataclasses import replace

    from brake_hil.diagnosis.dataset import noise_variances

    opened = _opened("one_washer_lti")
    ds = prepare(opened.recording, opened.rig)
    assert ds.noise_variance is None  # steady pulsing: today's estimate
    cycles = ds.noise_cost()
    without = replace(
        ds,
        segments=tuple(replace(w, kind="modulated") for w in ds.segments),
        noise_variance=noise_variances(opened.recording),
    )
    assert cycles / 1.5 < without.noise_cost() < 1.5 * cycles


@pytest.mark.parametrize(
    ("name", "shows"), [("ramp_one_washer", "static map"), ("sweep_one_washer", "sweep")]
)
def test_the_bundled_ramp_and_sweep_are_diagnosed(name: str, shows: str, tmp_path: Path) -> None:
    result = run_diagnose(BAGS / name, BAGS / f"{name}.rig.yaml", tmp_path / "out")
    diagnosis = result.diagnosis
    # the truth is a symmetric stick-slip seal (bags/README.md); on the ramp the groove's law
    # (stick-slip with a creeping rest position) fits the slow ramp better and is named
    assert {"seal_stick_slip", "seal_groove_asymmetry"} & set(diagnosis.effects)
    if name.startswith("sweep"):
        assert "seal_stick_slip" in diagnosis.effects
    assert any(shows in line for line in diagnosis.evidence.findings)
    page = result.report_path.read_text()
    alt = "static map over the ramps" if name.startswith("ramp") else "frequency response"
    assert alt in page


def test_a_procedure_keeps_its_pulsing_windows_and_adds_the_sweep_and_ramps() -> None:
    """A virtual-rig procedure: pulsing at 5 Hz, a 5-25 Hz sweep, a slow rise and fall."""
    import numpy as np

    from brake_hil.physics.rig import load_rig
    from brake_hil.virtual_rig.excitation import (
        Excitation,
        frequency_sweep,
        pressure_ramp,
        seed_pulsing,
    )
    from brake_hil.virtual_rig.simulator import simulate_rig
    from test.conftest import CONFIG

    pulsing = seed_pulsing((1.38e6,), pulsing_s=4.0)
    sweep = frequency_sweep(float(pulsing.pressure[-1]), 0.3e6, sweep_s=6.0)
    step = float(pulsing.time[1] - pulsing.time[0])
    start = int(round(1.0 / step))  # after the sweep's own ramp
    ramp = pressure_ramp(2.76e6, rest_s=0.5)
    pressure = np.concatenate([pulsing.pressure, sweep.pressure[start:], ramp.pressure])
    excitation = Excitation(np.arange(pressure.size) * step, pressure, pulsing.kind, "procedure")
    rig = load_rig(CONFIG / "rig_default.yaml")
    ds = prepare(simulate_rig(rig, [], excitation, seed=5).as_recording(), rig)
    kinds = [w.kind for w in ds.segments]
    assert kinds[0] == "steady" and "sweep" in kinds and kinds.count("ramp") == 2
    assert ds.noise_variance is None  # the steady pulsing's own noise estimate
    alone = prepare(simulate_rig(rig, [], pulsing, seed=5).as_recording(), rig)
    steady = [t for w in ds.train if w.kind == "steady" for t in (w.start, w.end)]
    assert steady == pytest.approx([t for w in alone.train for t in (w.start, w.end)], abs=0.02)
    assert {"steady", "sweep", "ramp"} <= {w.kind for w in ds.held_out}
