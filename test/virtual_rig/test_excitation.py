"""Inputs of the virtual rig: the seed's pulsing, a ramp, a 5-25 Hz sweep, the solenoid."""

from __future__ import annotations

import numpy as np
import pytest

from brake_hil.physics.excitation import SEED_MAX_PRESSURES, PulsingSchedule
from brake_hil.physics.lti_model import ModelInput
from brake_hil.physics.rig import Rig
from brake_hil.virtual_rig import (
    EffectError,
    Excitation,
    frequency_sweep,
    pressure_ramp,
    seed_pulsing,
    solenoid_pulsing,
)
from brake_hil.virtual_rig.excitation import seed_pulsing_from, solenoid_pulsing_from
from brake_hil.virtual_rig.simulator import master_pressure_estimate


def test_seed_pulsing_holds_the_three_maximum_pressures() -> None:
    excitation = seed_pulsing(SEED_MAX_PRESSURES)
    assert excitation.duration == pytest.approx(17.999)
    assert excitation.kind is ModelInput.MASTER_CYLINDER_PRESSURE
    for segment, maximum in enumerate(SEED_MAX_PRESSURES):
        window = (excitation.time >= 6 * segment + 1) & (excitation.time < 6 * segment + 6)
        assert np.max(excitation.pressure[window]) == pytest.approx(maximum, rel=1e-3)


def test_sweep_runs_from_5_to_25_hz() -> None:
    excitation = frequency_sweep(1.08e6, 0.3e6, ramp_s=1.0, sweep_s=10.0)
    sweep = excitation.time >= 1.0
    time, pressure = excitation.time[sweep], excitation.pressure[sweep] - 1.08e6
    rising = time[1:][(pressure[:-1] < 0.0) & (pressure[1:] >= 0.0)]
    frequency = 1.0 / np.diff(rising)
    assert frequency[0] == pytest.approx(5.0, abs=0.7)
    assert frequency[-1] == pytest.approx(25.0, abs=1.0)
    assert np.corrcoef(rising[1:], frequency)[0, 1] > 0.99  # linear in time


def test_ramp_rises_holds_and_falls_linearly() -> None:
    excitation = pressure_ramp(2.0e6, rest_s=0.5, rise_s=2.0, hold_s=1.0, fall_s=2.0)
    assert excitation.pressure[0] == 0.0 and excitation.pressure[-1] == 0.0
    assert np.max(excitation.pressure) == 2.0e6
    rising = (excitation.time > 0.6) & (excitation.time < 2.4)
    assert np.allclose(np.diff(excitation.pressure[rising]), 1.0e6 * 1e-3)


def test_solenoid_drives_the_master_cylinder_to_the_maximum_pressures(nominal_rig: Rig) -> None:
    excitation = solenoid_pulsing(nominal_rig, (1.38e6, 2.76e6), pulsing_s=3.0)
    assert excitation.air_driven
    master = master_pressure_estimate(nominal_rig, excitation)
    for segment, maximum in enumerate((1.38e6, 2.76e6)):
        window = (excitation.time >= 4 * segment + 2) & (excitation.time < 4 * segment + 4)
        assert np.max(master[window]) == pytest.approx(maximum, rel=0.03)
        air = excitation.pressure[window]
        assert np.ptp(air) / np.max(air) == pytest.approx(0.44, rel=0.05)


def test_excitation_refuses_bad_samples() -> None:
    time = np.arange(5) * 1e-3
    with pytest.raises(EffectError, match="non-finite"):
        Excitation(time, np.array([0, 1, np.nan, 1, 0.0]), ModelInput.AIR_PRESSURE, "bad")
    with pytest.raises(EffectError, match="time must increase"):
        Excitation(time[::-1], np.zeros(5), ModelInput.AIR_PRESSURE, "bad")


def test_seed_and_solenoid_pulsing_build_from_one_schedule(nominal_rig: Rig) -> None:
    schedule = PulsingSchedule((1.1e6, 2.2e6), ramp_s=0.4, pulsing_s=0.8, pulsing_hz=6.0)
    arguments = {"ramp_s": 0.4, "pulsing_s": 0.8, "pulsing_hz": 6.0}
    seed = seed_pulsing((1.1e6, 2.2e6), **arguments)
    from_schedule = seed_pulsing_from(schedule)
    assert seed.pressure.tobytes() == from_schedule.pressure.tobytes()
    assert seed.pressure.tobytes() == schedule.profile()[1].tobytes()
    assert seed.label == from_schedule.label
    solenoid = solenoid_pulsing(nominal_rig, (1.1e6, 2.2e6), **arguments)
    solenoid_from_schedule = solenoid_pulsing_from(nominal_rig, schedule)
    assert solenoid.pressure.tobytes() == solenoid_from_schedule.pressure.tobytes()
    assert solenoid.time.size == schedule.samples


def _kinds(excitation: Excitation) -> list[str]:
    from brake_hil.analysis import signals
    from brake_hil.analysis.segmentation import find_segments

    filtered = signals.lowpass(excitation.pressure, 1000.0)
    return [
        s.kind + ("*" if s.steady else "")
        for s in find_segments(excitation.time, filtered, 1000.0, 5.0)
    ]


def test_a_procedure_chains_pulsing_a_sweep_a_slow_ramp_and_an_abs_train() -> None:
    """Pulsing at three pressures, a 5-25 Hz sweep, a ramp and release, an ABS-like train."""
    from brake_hil.virtual_rig.excitation import procedure

    drive = procedure(SEED_MAX_PRESSURES, pulsing_s=3.0)
    kinds = _kinds(drive)
    assert kinds.count("pulsing*") == 3  # steady, the paper's Tables 3-5 apply
    sweep = kinds.index("sweep")
    assert kinds.index("ramp", sweep) < kinds.index("modulated", sweep)
    rises = [k for k in kinds[sweep:] if k == "ramp"]
    assert len(rises) >= 2  # the slow rise and its release
    assert drive.pressure.max() == pytest.approx(max(SEED_MAX_PRESSURES), rel=1e-3)
    assert drive.pressure.min() >= 0.0
    assert np.max(np.abs(np.diff(drive.pressure))) < 0.1e6  # no jump between parts (25 Hz: 95 kPa)
    assert "procedure" in drive.label and "ABS" in drive.label


def test_named_excitations_and_their_air_driven_form(nominal_rig: Rig) -> None:
    from brake_hil.virtual_rig.excitation import EXCITATION_KINDS, air_driven, named_excitation

    pressures = (1.0e6, 2.0e6)
    for kind in EXCITATION_KINDS:
        drive = named_excitation(kind, pressures, pulsing_s=1.0, pulsing_hz=5.0)
        assert drive.kind is ModelInput.MASTER_CYLINDER_PRESSURE
        assert drive.pressure.max() == pytest.approx(2.0e6, rel=0.01)
        air = air_driven(nominal_rig, drive)
        assert air.air_driven and "air-driven" in air.label
        master = nominal_rig.master_cylinder
        gain = (master.diameter / master.air_piston_diameter) ** 2
        np.testing.assert_allclose(air.pressure, drive.pressure * gain)
    assert "sweep" in _kinds(named_excitation("sweep", pressures, pulsing_s=2, pulsing_hz=5))
    with pytest.raises(EffectError, match="unknown excitation 'chirp'"):
        named_excitation("chirp", pressures, pulsing_s=1.0, pulsing_hz=5.0)
