"""The virtual rig's integration: the LTI model when no effect is on, accuracy, stability, DAQ."""

from __future__ import annotations

import numpy as np
import pytest

from brake_hil.analysis.comparison import predict
from brake_hil.physics.lti_model import air_driven_state_space, discretize, simulate
from brake_hil.physics.measurement import SENSORS
from brake_hil.physics.parameters import derive_parameters
from brake_hil.physics.rig import Rig
from brake_hil.virtual_rig import (
    EFFECTS,
    EffectError,
    frequency_sweep,
    make_effect,
    pressure_ramp,
    seed_pulsing,
    simulate_rig,
    solenoid_pulsing,
)
from brake_hil.virtual_rig.simulator import operating_pressure_schedule
from test.virtual_rig.conftest import RunFactory

CHANNELS = ("p_b", "F_k", "x_c")


def _nrmse(value: np.ndarray, reference: np.ndarray) -> float:
    return float(np.sqrt(np.mean((value - reference) ** 2)) / np.ptp(reference))


def test_with_no_effect_the_rig_is_the_lti_model(nominal_rig: Rig) -> None:
    excitation = seed_pulsing((1.38e6,), pulsing_s=3.0)
    mean = float(np.mean(excitation.pressure[excitation.time >= 1.0]))
    run = simulate_rig(nominal_rig, (), excitation, operating_pressure=mean)
    reference = predict(excitation.pressure, derive_parameters(nominal_rig, mean))
    for channel in CHANNELS:
        assert _nrmse(run.true()[channel], reference[channel]) < 1e-3, channel


def test_with_no_effect_each_segment_sits_at_its_own_mean_pressure(rig_run: RunFactory) -> None:
    run = rig_run(max_pressures=(1.38e6, 2.76e6), pulsing_s=3.0)
    steady = (run.time >= 5.2) & (run.time < 7.0)  # second segment's pulsing
    mean = float(np.mean(run.master_cylinder_pressure[(run.time >= 5.0) & (run.time < 7.0)]))
    reference = predict(run.master_cylinder_pressure, derive_parameters(run.plant.rig, mean))
    for channel in CHANNELS:
        assert _nrmse(run.true()[channel][steady], reference[channel][steady]) < 1e-3, channel


def test_with_no_effect_and_an_undamped_master_cylinder_the_air_driven_rig_is_eq_21a_f(
    nominal_rig: Rig,
) -> None:
    """Eq. 21a leaves the master piston's ~270 Hz mode undamped; the solver tracks its ringing
    at a tight tolerance."""
    excitation = solenoid_pulsing(nominal_rig, (1.38e6,), pulsing_s=1.0)
    mean = 0.9e6
    run = simulate_rig(
        nominal_rig, (), excitation, operating_pressure=mean, master_damping_ratio=0.0, rtol=1e-6
    )
    system = air_driven_state_space(derive_parameters(nominal_rig, mean))
    reference = simulate(discretize(system), excitation.pressure)
    for row, channel in enumerate((*CHANNELS, "p_i")):
        assert _nrmse(run.true()[channel], reference[row]) < 1e-3, channel
    assert run.air_pressure is not None and "p_a" in run.measured


def test_compliance_follows_eq_18_at_the_operating_pressure(rig_run: RunFactory) -> None:
    run = rig_run(max_pressures=(1.38e6, 2.76e6), pulsing_s=3.0)
    for t in (3.0, 6.5):
        index = int(np.searchsorted(run.time, t))
        pressure = float(run.internals["operating_pressure"][index])
        expected = derive_parameters(run.plant.rig, pressure).bore_compliance
        assert run.internals["bore_compliance"][index] == pytest.approx(expected, rel=1e-12)


def test_operating_pressure_is_the_mean_over_one_period() -> None:
    time = np.arange(0.0, 2.0, 1e-3)
    pressure = 1.0e6 + 3.0e5 * np.sin(2 * np.pi * 5.0 * time)
    schedule = operating_pressure_schedule(time, pressure, 0.2)
    assert np.allclose(schedule, 1.0e6, rtol=1e-9)


def test_solver_matches_a_tighter_solve_with_every_effect(nominal_rig: Rig) -> None:
    excitation = seed_pulsing((2.76e6,), ramp_s=0.5, pulsing_s=0.6)
    effects = [make_effect(name) for name in EFFECTS]
    run = simulate_rig(nominal_rig, effects, excitation)
    tight = simulate_rig(nominal_rig, effects, excitation, rtol=1e-7, max_step=5e-4)
    for channel in CHANNELS:
        assert _nrmse(run.true()[channel], tight.true()[channel]) < 1e-4, channel


@pytest.mark.parametrize(
    "kind", ["ramp", "sweep", "solenoid"], ids=["ramp", "5-25 Hz sweep", "solenoid"]
)
def test_every_effect_at_once_is_stable_for_every_excitation(nominal_rig: Rig, kind: str) -> None:
    if kind == "ramp":
        excitation = pressure_ramp(2.76e6, rest_s=0.2, rise_s=0.6, hold_s=0.2, fall_s=0.6)
    elif kind == "sweep":
        excitation = frequency_sweep(1.08e6, 0.3e6, ramp_s=0.3, sweep_s=1.0)
    else:
        excitation = solenoid_pulsing(nominal_rig, (2.76e6,), ramp_s=0.5, pulsing_s=0.8)
    effects = [make_effect(name) for name in EFFECTS]
    run = simulate_rig(nominal_rig, effects, excitation)
    for channel, values in run.true().items():
        assert np.all(np.isfinite(values)), channel
    assert np.max(run.bore_pressure) < 1.2 * np.max(run.master_cylinder_pressure)
    assert np.min(run.caliper_displacement) > -3e-4


def test_daq_adds_noise_and_quantises_to_16_bits_over_the_sensor_ranges(
    rig_run: RunFactory,
) -> None:
    run = rig_run()
    assert np.allclose(np.diff(run.time), 1e-3)
    for channel in ("p_i", *CHANNELS):
        sensor = SENSORS[channel]
        counts = (run.measured[channel] - sensor.low) / sensor.resolution
        assert np.allclose(counts, np.round(counts), atol=1e-6), channel
        noise = run.measured[channel] - run.true()[channel]
        assert np.std(noise) == pytest.approx(sensor.noise_rms, rel=0.1), channel


def test_run_exposes_true_and_measured_arrays_of_one_length(rig_run: RunFactory) -> None:
    run = rig_run()
    arrays = [*run.true().values(), *run.measured.values(), *run.internals.values()]
    assert {a.shape for a in arrays} == {run.time.shape}
    recording = run.as_recording()
    assert recording.bore_pressure is run.measured["p_b"]
    assert run.as_recording(measured=False).caliper_displacement is run.caliper_displacement


def test_an_effect_given_twice_is_refused(nominal_rig: Rig) -> None:
    with pytest.raises(EffectError, match="orifice_flow is given more than once"):
        simulate_rig(
            nominal_rig,
            [make_effect("orifice_flow"), make_effect("orifice_flow", 0.5)],
            seed_pulsing(pulsing_s=0.5),
        )
