"""Each effect moves the recording in its documented direction (checked numerically).

Runs are short (one ramp, then 3 s of 5 Hz pulsing) and compared over their last 2 s with the
same rig without the effect.
"""

from __future__ import annotations

import numpy as np

from brake_hil.analysis import signals
from brake_hil.analysis.characterization import characterize
from brake_hil.virtual_rig import RigRun
from test.virtual_rig.conftest import RunFactory

FREQUENCY = 5.0


def _steady(run: RigRun, seconds: float = 2.0) -> np.ndarray:
    return run.time >= run.time[-1] - seconds + 1e-9


def _ptp_ratio(run: RigRun, reference: RigRun, channel: str) -> float:
    steady = _steady(run)
    return float(np.ptp(run.true()[channel][steady]) / np.ptp(reference.true()[channel][steady]))


def _lag_s(run: RigRun, reference: RigRun, channel: str, measured: bool = False) -> float:
    """How much later (s) ``channel`` of ``run`` crosses than ``reference``'s, at 5 Hz."""
    steady = _steady(run)
    time = run.time[steady]
    values = (run.measured if measured else run.true())[channel][steady]
    phasor = signals.harmonic_phasor(values, time, FREQUENCY)
    reference_phasor = signals.harmonic_phasor(reference.true()[channel][steady], time, FREQUENCY)
    return float(-np.angle(phasor / reference_phasor) / (2 * np.pi * FREQUENCY))


def test_eccentric_load_scales_x_c_and_not_p_b(rig_run: RunFactory) -> None:
    plain, loaded = rig_run(), rig_run(("eccentric_load", 1.0))
    x_c_change = 1.0 - _ptp_ratio(loaded, plain, "x_c")
    assert x_c_change > 0.08  # the caliper sees less force: x_c over-predicted, as in Table 5
    assert abs(1.0 - _ptp_ratio(loaded, plain, "p_b")) < 0.1 * x_c_change
    assert abs(_lag_s(loaded, plain, "x_c")) < 2e-3


def test_sensor_delay_shifts_one_channel_by_the_set_delay(rig_run: RunFactory) -> None:
    plain = rig_run()
    skewed = rig_run(("sensor_delay", 0.75, {"channel": "F_k", "delay": 4e-3}))
    assert abs(_lag_s(skewed, plain, "F_k", measured=True) - 3e-3) < 5e-5
    assert np.array_equal(skewed.true()["F_k"], plain.true()["F_k"])
    for channel in ("p_i", "p_b", "x_c"):
        assert np.array_equal(skewed.measured[channel], plain.measured[channel])


def test_entrained_air_lowers_and_delays_p_b_at_low_pressure(rig_run: RunFactory) -> None:
    low = {"max_pressures": (0.5e6,)}
    high = {"max_pressures": (2.76e6,)}
    ratio_low = _ptp_ratio(rig_run(("entrained_air", 1.0), **low), rig_run(**low), "p_b")
    ratio_high = _ptp_ratio(rig_run(("entrained_air", 1.0), **high), rig_run(**high), "p_b")
    lag_low = _lag_s(rig_run(("entrained_air", 1.0), **low), rig_run(**low), "p_b")
    lag_high = _lag_s(rig_run(("entrained_air", 1.0), **high), rig_run(**high), "p_b")
    assert ratio_low < 0.95 and ratio_low < ratio_high
    assert lag_low > 5e-3 and lag_low > 5 * lag_high > 0.0


def test_orifice_flow_reduces_p_b_more_at_larger_amplitude(rig_run: RunFactory) -> None:
    ratios = [
        _ptp_ratio(
            rig_run(("orifice_flow", 1.0), max_pressures=(p,)), rig_run(max_pressures=(p,)), "p_b"
        )
        for p in (0.5e6, 1.38e6, 2.76e6)
    ]
    assert ratios[0] > ratios[1] > ratios[2]
    assert ratios[0] - ratios[2] > 0.05


def test_hose_compliance_delays_and_filters_p_b(rig_run: RunFactory) -> None:
    plain, soft = rig_run(), rig_run(("hose_compliance", 1.0))
    assert _lag_s(soft, plain, "p_b") > 2e-3
    assert _ptp_ratio(soft, plain, "p_b") < 0.995


def test_seal_stick_slip_shows_the_seeds_signatures(rig_run: RunFactory) -> None:
    """k_eh falls as the pressure amplitude grows (Table 3); x_c gains super-harmonics that p_i
    does not have (Table 1)."""
    run = rig_run(("seal_stick_slip", 1.0), max_pressures=(1.38e6, 2.07e6, 2.76e6))
    segments = characterize(run.as_recording(), run.plant.rig)
    assert len(segments) == 3
    stiffness = [segment.k_eh for segment in segments]
    assert stiffness[0] > 1.3 * stiffness[1] > 1.3 * 1.3 * stiffness[2]
    for segment in segments:
        shares = segment.harmonic_energy_pct
        assert sum(shares["x_c"][1:3]) > 3 * sum(shares["p_i"][1:3]) + 0.02
    plain = rig_run(max_pressures=(1.38e6, 2.07e6, 2.76e6))
    lti = characterize(plain.as_recording(), plain.plant.rig)
    assert np.ptp([segment.k_eh for segment in lti]) < 0.02 * lti[0].k_eh


def test_bore_friction_adds_damping(rig_run: RunFactory) -> None:
    plain, rubbing = rig_run(), rig_run(("bore_friction", 1.0))
    rig = plain.plant.rig
    damping = characterize(rubbing.as_recording(), rig)[0].c_eh
    assert damping > 1.2 * characterize(plain.as_recording(), rig)[0].c_eh
    assert _ptp_ratio(rubbing, plain, "x_c") < 0.97


def test_seal_groove_asymmetry_adds_an_even_harmonic_to_x_c(rig_run: RunFactory) -> None:
    plain, lopsided = rig_run(), rig_run(("seal_groove_asymmetry", 1.0))
    steady = _steady(plain)
    second = signals.harmonic_energy_shares(lopsided.caliper_displacement[steady], 1000.0)[1]
    assert second > 0.01
    assert (
        second > 100 * signals.harmonic_energy_shares(plain.caliper_displacement[steady], 1e3)[1]
    )


def test_thermal_drift_makes_the_mismatch_grow_over_the_recording(rig_run: RunFactory) -> None:
    plain, warming = rig_run(pulsing_s=6.0), rig_run(("thermal_drift", 1.0), pulsing_s=6.0)
    difference = warming.caliper_displacement - plain.caliper_displacement
    early = difference[(plain.time >= 1.2) & (plain.time < 2.2)]
    late = difference[plain.time >= 6.0]
    assert np.std(late) > 2.0 * np.std(early)
    temperature = warming.internals["temperature"]
    assert np.all(np.diff(temperature) >= 0.0) and temperature[-1] - temperature[0] > 10.0
