"""Family c: a third law of every effect and of the measurement chain, from the physics alone."""

from __future__ import annotations

from functools import cache
import json
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest

from brake_hil.analysis.comparison import predict
from brake_hil.physics import catalogue
from brake_hil.physics.parameters import derive_parameters
from brake_hil.virtual_rig import RigRun, seed_pulsing, simulate_rig
from brake_hil.virtual_rig.cases import FAMILIES, measurement_chain, nominal_rigs, plan_cases
from brake_hil.virtual_rig.effects import EFFECTS, Effect, EffectError
from brake_hil.virtual_rig.family_c import EFFECTS_C, OUTSIDE_C, FamilyCEffect, MeasurementChainC
from brake_hil.virtual_rig.family_c.sensor_delay import SensorDelayC, fractional_delay
from brake_hil.virtual_rig.plant import build_plant

CHANNELS = ("p_b", "F_k", "x_c")
EVERY_LAW = {**EFFECTS_C, **OUTSIDE_C}
RIG = nominal_rigs()["one_washer_open"]
# short runs: a ramp to the seed's top level, then 0.8 s of 5 Hz pulsing
EXCITATION = seed_pulsing((2.76e6,), pulsing_s=0.8)
PULSING = EXCITATION.time >= 1.0
# parameters that let a slow law show within the short run
SHORT_RUN_PARAMETERS: dict[str, dict[str, float]] = {
    "thermal_drift": {"time_constant": 2.0, "delay": 0.0},
    "seal_groove_asymmetry": {"creep_time": 0.2},
}


def _nrmse(value: np.ndarray, reference: np.ndarray) -> float:
    return float(np.sqrt(np.mean((value - reference) ** 2)) / np.ptp(reference))


@cache
def _run(name: str, strength: float) -> RigRun:
    effects: list[Effect] = []
    if name:
        effects = [EVERY_LAW[name](strength, **SHORT_RUN_PARAMETERS.get(name, {}))]
    return simulate_rig(RIG, effects, EXCITATION, seed=11)


def _change(name: str, strength: float) -> dict[str, float]:
    """Each measured channel's change by the law (NRMSE over the pulsing, same noise)."""
    plain, run = _run("", 0.0), _run(name, strength)
    return {
        channel: _nrmse(run.measured[channel][PULSING], plain.measured[channel][PULSING])
        for channel in CHANNELS
    }


def test_family_c_has_a_law_of_its_own_for_every_library_effect() -> None:
    assert tuple(EFFECTS_C) == tuple(catalogue.CATALOGUE)
    for name, cls in EFFECTS_C.items():
        assert issubclass(cls, FamilyCEffect) and cls.family == "c"
        assert cls.__module__.startswith("brake_hil.virtual_rig.family_c.")
        assert cls is not EFFECTS[name]
        assert cls.entry is catalogue.entry(name) and cls.signature == cls.entry.signature


def test_family_c_outside_effects_are_outside_the_library_and_the_catalogue() -> None:
    assert len(OUTSIDE_C) >= 2
    for name, cls in OUTSIDE_C.items():
        assert name not in catalogue.CATALOGUE and name not in catalogue.OUT_OF_LIBRARY
        assert cls.name == name and cls.entry.name == name


@pytest.mark.parametrize("name", tuple(EVERY_LAW))
def test_family_c_law_declares_units_bounds_and_draws_within_them(name: str) -> None:
    cls = EVERY_LAW[name]
    assert cls.parameters[0].name == "strength"
    text = cls(0.5).describe()
    assert text.startswith(f"{name}: ") and "strength = 0.5" in text
    for parameter in cls.parameters:
        assert parameter.unit and parameter.description
        assert parameter.choices or parameter.low <= parameter.high
    first = cls.draw(np.random.default_rng(4), 0.6)
    again = cls.draw(np.random.default_rng(4), 0.6)
    assert first == again and first.strength == 0.6  # bounds are checked on construction
    draws = [cls.draw(np.random.default_rng(seed), 0.6) for seed in range(20)]
    assert all(type(draw) is cls for draw in draws)


@pytest.mark.parametrize("name", tuple(EVERY_LAW))
def test_family_c_law_at_strength_zero_leaves_the_rig_at_eq_21(name: str) -> None:
    excitation = seed_pulsing((1.38e6,), pulsing_s=0.6)
    mean = float(np.mean(excitation.pressure[excitation.time >= 1.0]))
    effect = EVERY_LAW[name](0.0)
    assert build_plant(RIG, [effect]).laws == ()
    run = simulate_rig(RIG, [effect], excitation, operating_pressure=mean)
    reference = predict(excitation.pressure, derive_parameters(RIG, mean))
    for channel in CHANNELS:
        assert _nrmse(run.true()[channel], reference[channel]) < 1e-3, channel


@pytest.mark.parametrize("name", tuple(EVERY_LAW))
def test_family_c_law_at_full_strength_changes_its_channels_by_a_few_percent(name: str) -> None:
    change = _change(name, 1.0)
    reached = EVERY_LAW[name].entry.channels
    assert max(change[channel] for channel in reached) > 0.008, change
    assert max(change.values()) < 0.25, change  # a change of physical size, not a blow-up
    for channel in set(CHANNELS) - set(reached):
        assert change[channel] < 0.5 * max(change[c] for c in reached), (channel, change)


@pytest.mark.parametrize("name", ("seal_stick_slip", "hose_compliance", "eccentric_load"))
def test_family_c_law_at_a_subtle_strength_changes_less(name: str) -> None:
    strong, subtle = _change(name, 1.0), _change(name, 0.15)
    assert 0.0005 < max(subtle.values()) < 0.5 * max(strong.values()), (subtle, strong)


def test_family_c_laws_take_the_rig_together_on_separate_ports() -> None:
    plant = build_plant(RIG, [cls(0.5) for cls in EFFECTS_C.values()])
    assert len(plant.laws) == len(EFFECTS_C)


def test_family_c_groove_asymmetry_makes_the_apply_and_release_halves_differ() -> None:
    t = EXCITATION.time[PULSING]
    plain = _run("", 0.0).caliper_displacement[PULSING]

    def harmonic(name: str, hz: float) -> float:
        """Amplitude (m) at ``hz`` of what the law changes in x_c (a linear trend taken out)."""
        change = _run(name, 1.0).caliper_displacement[PULSING] - plain
        change = change - np.polyval(np.polyfit(t, change, 1), t)
        return float(abs(np.mean(change * np.exp(-2j * np.pi * hz * t))))

    # lopsided halves: the change is mostly at twice the pulsing, unlike a symmetric law's
    assert harmonic("seal_groove_asymmetry", 10.0) > 2.0 * harmonic("seal_groove_asymmetry", 5.0)
    assert harmonic("eccentric_load", 10.0) < 0.2 * harmonic("eccentric_load", 5.0)


def test_family_c_sensor_delay_lags_its_channel_by_the_set_delay() -> None:
    time = np.arange(2000) / 1000.0
    signal = np.sin(2 * np.pi * 5.0 * time)
    for delay in (0.3e-3, 1.0e-3, 2.7e-3):
        delayed = fractional_delay(signal, delay * 1000.0)
        expected = np.sin(2 * np.pi * 5.0 * (time - delay))
        assert np.max(np.abs(delayed[200:] - expected[200:])) < 2e-3, delay
    law = SensorDelayC(1.0, channel="F_k", delay=3e-3).law(build_plant(RIG))
    assert law.acquisition("p_b", time, signal) is signal


def test_family_c_measurement_chain_is_no_effect_and_is_seeded() -> None:
    spec = next(s for s in plan_cases(4, 7, family="c") if s.kind == "single")
    (chain,) = measurement_chain(spec)
    assert isinstance(chain, MeasurementChainC) and chain.seed == spec.noise_seed
    assert chain.name not in catalogue.CATALOGUE and chain.name not in EFFECTS_C
    time = np.arange(3000) / 1000.0
    values = 1.0e6 + 3.0e5 * np.sin(2 * np.pi * 5.0 * time)
    law = chain.law(build_plant(RIG))
    once, twice = law.acquisition("p_b", time, values), law.acquisition("p_b", time, values)
    np.testing.assert_array_equal(once, twice)
    other = MeasurementChainC(seed=chain.seed + 1).law(build_plant(RIG))
    assert not np.array_equal(once, other.acquisition("p_b", time, values))
    # within a lab's specification: a fraction of a percent of the pulsing, not an effect
    assert 1e-4 < _nrmse(once, values) < 5e-3


def test_family_c_plan_is_deterministic_and_covers_every_effect_in_its_first_round() -> None:
    assert "c" in FAMILIES
    plan = plan_cases(26, 9, family="c")
    again = plan_cases(26, 9, family="c")
    assert [(s.kind, s.effects, s.parameter_errors, s.noise_seed) for s in plan] == [
        (s.kind, s.effects, s.parameter_errors, s.noise_seed) for s in again
    ]
    assert all(s.family == "c" for s in plan)
    singles = [s.effects[0] for s in plan if s.kind == "single"]
    assert {e.name for e in singles} == set(EFFECTS_C)
    assert all(type(e) is EFFECTS_C[e.name] for e in singles)
    outside = [s.effects[0] for s in plan if s.kind == "unexplained"]
    assert outside and all(type(e) is OUTSIDE_C[e.name] for e in outside)
    family_a = plan_cases(26, 9)
    assert [s.noise_seed for s in family_a] != [s.noise_seed for s in plan]


def test_an_unknown_family_is_still_refused() -> None:
    with pytest.raises(EffectError, match="family"):
        plan_cases(3, 0, family="d")


def test_cases_command_writes_family_c_cases(tmp_path: Path) -> None:
    out = tmp_path / "bench"
    result = subprocess.run(
        [sys.executable, "-m", "brake_hil.cli", "cases", "--family", "c", "--count", "2",
         "--seed", "5", "--out", str(out), "--pulsing-seconds", "0.5", "--serial"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    document = json.loads((out / "labels.json").read_text())
    assert document["generator"]["family"] == "c"
    labels = document["cases"]
    assert sorted(labels) == ["000", "001"]
    for spec in plan_cases(2, 5, family="c"):
        label = labels[spec.case_id]
        assert label["family"] == "c" and label["kind"] == spec.kind
        assert [e["name"] for e in label["effects"]] == [e.name for e in spec.effects]
        assert label["measurement_chain"][0]["name"] == "daq_c"
        assert "daq_c" not in label["expected_effects"]
        assert (out / "cases" / spec.case_id / "recording" / "metadata.yaml").is_file()
