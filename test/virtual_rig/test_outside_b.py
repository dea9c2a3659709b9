"""Five more out-of-library truth laws (family_b/outside.py): registered once, each on its ports.

The module registers its laws when imported; these tests import it inside a fixture and take
the laws out again afterwards, so the rest of the suite sees the built-in ``OUT_OF_LIBRARY``
(the case schedule draws from it).
"""

from __future__ import annotations

from collections.abc import Iterator
import dataclasses
import importlib
from pathlib import Path
import re
import subprocess
import sys
import textwrap
from types import ModuleType

import numpy as np
import pytest

from brake_hil.diagnosis.candidates import CANDIDATES
from brake_hil.diagnosis.diagnose import diagnose
from brake_hil.physics import catalogue
from brake_hil.physics.excitation import SEED_MAX_PRESSURES
from brake_hil.physics.measurement import SENSORS
from brake_hil.virtual_rig import EffectError, make_effect, seed_pulsing, simulate_rig
from brake_hil.virtual_rig.cases import nominal_rigs
from brake_hil.virtual_rig.effects import OUT_OF_LIBRARY, effect_class
from brake_hil.virtual_rig.laws import LtiPlant
from test.virtual_rig.conftest import RunFactory

MODULE = "brake_hil.virtual_rig.family_b.outside"
NAMES = (
    "fluid_leak",
    "check_valve_bypass",
    "force_sensor_hysteresis",
    "pressure_tap_resonance",
    "pressure_zero_shift",
)
SHORT = {"max_pressures": (1.38e6,), "pulsing_s": 0.6}
SI_UNIT = re.compile(r"^(-|channel|(1|kg|m|s|N|Pa|K)(\^\d)?([ /*()]+(kg|m|s|N|Pa|K)(\^\d)?\)?)*)$")


@pytest.fixture
def plant(rig_run: RunFactory) -> LtiPlant:
    """The truth plant of the short run (what a law binds to)."""
    return rig_run(**SHORT).plant


@pytest.fixture(scope="module")
def outside() -> Iterator[ModuleType]:
    """The module, its five laws registered; unregistered afterwards unless they were before."""
    before = set(OUT_OF_LIBRARY)
    module = importlib.import_module(MODULE)
    module.register_outside()
    yield module
    if not before & set(NAMES):
        module.unregister_outside()


def test_the_five_are_registered_out_of_the_library_with_no_candidate(
    outside: ModuleType,
) -> None:
    assert outside.OUTSIDE_NAMES == NAMES
    assert tuple(OUT_OF_LIBRARY)[-5:] == NAMES
    candidate_names = {candidate.name for candidate in CANDIDATES}
    for name, cls in zip(NAMES, outside.OUTSIDE_LAWS):
        assert name in catalogue.OUT_OF_LIBRARY and name not in catalogue.CATALOGUE
        assert effect_class(name) is cls
        assert OUT_OF_LIBRARY[name] is cls
        assert cls.entry is catalogue.entry(name)
        assert name not in candidate_names


def test_importing_twice_registers_once(outside: ModuleType) -> None:
    again = importlib.import_module(MODULE)
    assert again is outside
    assert outside.register_outside() == ()
    assert [name for name in OUT_OF_LIBRARY if name in NAMES] == list(NAMES)
    assert [name for name in catalogue.OUT_OF_LIBRARY if name in NAMES] == list(NAMES)


def test_a_reload_and_a_spawned_worker_register_once(tmp_path: Path) -> None:
    """In a fresh interpreter (the session's registry untouched): reload, then a worker."""
    script = tmp_path / "twice.py"
    script.write_text(
        textwrap.dedent(
            f"""
            import concurrent.futures
            import importlib
            import multiprocessing

            from brake_hil.physics import catalogue
            from brake_hil.virtual_rig.effects import OUT_OF_LIBRARY, effect_class

            NAMES = {NAMES!r}
            MODULE = {MODULE!r}


            def registered():
                return [n for n in OUT_OF_LIBRARY if n in NAMES]


            def reload_and_register():
                module = importlib.reload(importlib.import_module(MODULE))
                return module.register_outside()


            if __name__ == "__main__":
                module = importlib.import_module(MODULE)
                first = module.FluidLeak
                module = importlib.reload(module)
                assert module.FluidLeak is not first
                assert effect_class("fluid_leak") is module.FluidLeak
                assert module.FluidLeak.entry is catalogue.entry("fluid_leak")
                assert module.register_outside() == ()
                assert registered() == list(NAMES)
                assert [n for n in catalogue.OUT_OF_LIBRARY if n in NAMES] == list(NAMES)
                context = multiprocessing.get_context("spawn")
                with concurrent.futures.ProcessPoolExecutor(1, mp_context=context) as pool:
                    # unpickling an effect imports the module in the worker
                    effect = module.FluidLeak(0.5)
                    assert pool.submit(getattr, effect, "name").result() == "fluid_leak"
                    assert pool.submit(reload_and_register).result() == ()
                    assert pool.submit(registered).result() == list(NAMES)
                    found = pool.submit(effect_class, "pressure_zero_shift").result()
                    assert found is module.PressureZeroShift  # pickled by name
                print("ok")
            """
        )
    )
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"


@pytest.mark.parametrize("name", NAMES)
def test_each_law_has_units_bounds_a_source_and_no_diagnosis_model(
    outside: ModuleType, name: str
) -> None:
    cls = effect_class(name)
    description = cls.description()
    assert len(description) > 300 and "\n" not in description
    assert re.search(r"\d{4}", description[description.index("Source:") :])
    assert cls.diagnosis_model.startswith("none: outside the library")
    assert cls.signature == catalogue.entry(name).signature
    assert cls.parameters[0].name == "strength"
    default = cls()
    for parameter in cls.parameters:
        assert SI_UNIT.match(parameter.unit), (parameter.name, parameter.unit)
        assert parameter.low < parameter.high
        assert parameter.low <= getattr(default, parameter.name) <= parameter.high
    for quantity in cls.entry.quantities:
        assert SI_UNIT.match(quantity.unit), quantity
    with pytest.raises(EffectError, match=name):
        make_effect(name, 1.5)


@pytest.mark.parametrize("name", NAMES)
def test_draw_draws_the_secondary_parameters_within_bounds(outside: ModuleType, name: str) -> None:
    cls = effect_class(name)
    drawn = [cls.draw(np.random.default_rng(seed), 0.3) for seed in range(4)]
    assert all(effect.strength == 0.3 for effect in drawn)
    assert len({tuple(effect.values().items()) for effect in drawn}) > 1
    for effect in drawn:
        cls(**effect.values())  # type: ignore[arg-type]  # within bounds


@pytest.mark.parametrize("name", NAMES)
def test_strength_zero_gives_the_run_without_the_effect(
    outside: ModuleType, name: str, rig_run: RunFactory
) -> None:
    plain = rig_run(**SHORT)
    zero = rig_run((name, 0.0), **SHORT)
    assert not zero.effects
    for key in ("p_i", "p_b", "F_k", "x_c"):
        assert np.array_equal(zero.true()[key], plain.true()[key])
        assert np.array_equal(zero.measured[key], plain.measured[key])


@pytest.mark.parametrize("name", NAMES)
def test_strength_one_changes_the_entry_channels_and_leaves_the_others(
    outside: ModuleType, name: str, rig_run: RunFactory
) -> None:
    plain = rig_run(**SHORT)
    full = rig_run((name, 1.0), **SHORT)
    assert [effect.name for effect in full.effects] == [name]
    assert np.array_equal(full.measured["p_i"], plain.measured["p_i"])
    listed = catalogue.entry(name).channels
    for key in ("p_b", "F_k", "x_c"):
        difference = full.measured[key] - plain.measured[key]  # the same noise draws
        rms = float(np.sqrt(np.mean(difference**2)))
        noise = SENSORS[key].noise_rms
        if key in listed:
            assert rms > 2.0 * noise, (key, rms, noise)
        else:
            assert rms < 0.1 * noise, (key, rms, noise)


def test_the_leak_holds_p_b_below_p_i_and_the_bypass_empties_the_bore_faster(
    outside: ModuleType, rig_run: RunFactory
) -> None:
    plain = rig_run(**SHORT)
    steady = plain.time > 1.2
    plain_gap = float(
        np.mean(plain.bore_pressure[steady] - plain.master_cylinder_pressure[steady])
    )
    leak = rig_run(("fluid_leak", 1.0), **SHORT)
    gap = float(np.mean(leak.bore_pressure[steady] - leak.master_cylinder_pressure[steady]))
    assert gap - plain_gap < -5.0e3, (gap, plain_gap)
    bypass = rig_run(("check_valve_bypass", 1.0), **SHORT)
    for run, lopsided in ((plain, False), (bypass, True)):
        lag = run.master_cylinder_pressure[steady] - run.bore_pressure[steady]
        apply_over_release = float(lag.max() / -lag.min())  # the line's drop, both ways
        assert (apply_over_release > 1.3) is lopsided, apply_over_release


def test_the_hysteresis_is_bounded_rate_independent_and_returns_on_a_repeated_path(
    outside: ModuleType, plant: LtiPlant
) -> None:
    law = outside.ForceSensorHysteresis(1.0).law(plant)
    error = 0.01 * 8.9e3
    time = np.arange(4000) * 1e-3
    slow = 1000.0 + 800.0 * np.sin(2 * np.pi * 2.0 * time)
    read = law.acquisition("F_k", time, slow)
    assert np.max(np.abs(read - slow)) <= error * (1 + 1e-12)
    assert np.max(np.abs(read - slow)) > 0.9 * error  # every play taken up
    fast = law.acquisition("F_k", time / 4, slow)  # the same path four times faster
    assert np.array_equal(fast, read)
    later = read[2500:3000]  # steady loop: one period later the same reading
    assert np.allclose(read[3000:3500], later)
    assert law.acquisition("p_b", time, slow) is slow


def test_the_tap_amplifies_a_5_hz_pulsing_by_its_resonance(
    outside: ModuleType, plant: LtiPlant
) -> None:
    law = outside.PressureTapResonance(1.0, frequency=20.0, damping_ratio=0.1).law(plant)
    time = np.arange(6000) * 1e-3
    pressure = 1.0e6 + 3.0e5 * np.sin(2 * np.pi * 5.0 * time)
    read = law.acquisition("p_b", time, pressure)
    settled = time > 3.0
    gain = np.ptp(read[settled]) / np.ptp(pressure[settled])
    ratio = (5.0 / 20.0) ** 2
    expected = 1.0 / np.hypot(1.0 - ratio, 2 * 0.1 * 5.0 / 20.0)
    assert abs(gain - expected) < 2e-3
    assert abs(np.mean(read[settled]) - 1.0e6) < 1e3  # unit gain at rest


def test_the_zero_shift_follows_the_peak_pressure_over_its_creep_time(
    outside: ModuleType, plant: LtiPlant
) -> None:
    law = outside.PressureZeroShift(1.0, shift=0.01, creep_time=0.5).law(plant)
    time = np.arange(10000) * 1e-3
    pressure = np.where(time < 5.0, 1.0e6, 2.0e6) + 1.0e5 * np.sin(2 * np.pi * 5.0 * time)
    offset = law.acquisition("p_b", time, pressure) - pressure
    assert abs(offset[4999] - 0.01 * 1.1e6) < 50.0
    assert abs(offset[-1] - 0.01 * 2.1e6) < 50.0
    assert offset[5500] < 0.01 * 2.1e6 - 3e3  # still creeping half a second after the step


def test_the_bypass_drop_is_the_needle_on_apply_and_lower_on_release(
    outside: ModuleType, plant: LtiPlant
) -> None:
    law = outside.CheckValveBypass(1.0, release_relief=2.0 / 3.0, cracking_pressure=4.0e3).law(
        plant
    )
    resistance = 3.0e10
    flows = np.linspace(-4e-6, 4e-6, 801)
    drop = law.valve_drop(flows, resistance, 1.0, 1.0)
    assert np.all(np.diff(drop) > 0)  # monotonic: one flow per drop
    apply = flows > 1e-6
    assert np.allclose(drop[apply], resistance * flows[apply], rtol=0, atol=10.0)
    release = flows < -1e-6
    slope = np.diff(drop[release]) / np.diff(flows[release])
    assert np.allclose(slope, resistance / 3.0, rtol=1e-2)


def test_a_blind_diagnosis_of_a_strong_leak_names_no_library_effect(
    outside: ModuleType,
) -> None:
    """The most distinct of the five: p_b settles below p_i, which no candidate can do."""
    nominal = nominal_rigs()["one_washer_open"]
    truth = dataclasses.replace(nominal, caliper_stiffness=nominal.caliper_stiffness * 1.05)
    run = simulate_rig(
        truth,
        [make_effect("fluid_leak", 0.85)],
        seed_pulsing(SEED_MAX_PRESSURES, pulsing_s=5.0),
        seed=3,
    )
    result = diagnose(run.as_recording(), nominal)
    named = set(result.effects) & set(catalogue.CATALOGUE)
    assert not (named and result.confidence >= 0.8), (result.effects, result.confidence)
