"""The transducers as they read: a pressure zero that wanders, a channel held at a range's end."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from brake_hil.analysis.saturation import SATURATED_SAMPLES, held_limits
from brake_hil.diagnosis.dataset import ZERO_STABILITY, Window, read_as_measured
from brake_hil.diagnosis.thresholds import NOISE_EXCESS
from brake_hil.physics.measurement import SENSORS
from brake_hil.physics.rig import Rig


def test_a_pressure_zero_within_its_stability_is_levelled_and_a_larger_shift_is_kept() -> None:
    """Over a pulsing window the predicted ``p_b`` moves onto the measured zero by at most
    ``ZERO_STABILITY`` of its full scale; a ramp, ``F_k`` and ``x_c`` keep their levels."""
    bound = ZERO_STABILITY * (SENSORS["p_b"].high - SENSORS["p_b"].low)
    wave = np.sin(np.linspace(0.0, 20.0 * np.pi, 1000)) * 1e6
    pulsing, ramp = Window(0.0, 2.0, 1e6, 0), Window(0.0, 2.0, 1e6, 0, kind="ramp")
    within = read_as_measured(wave, wave + 0.5 * bound, pulsing, "p_b")
    assert within - (wave + 0.5 * bound) == pytest.approx(np.zeros(1000), abs=1e-6)
    beyond = read_as_measured(wave, wave + 3.0 * bound, pulsing, "p_b")
    assert (wave + 3.0 * bound) - beyond == pytest.approx(np.full(1000, 2.0 * bound))
    assert read_as_measured(wave, wave + 0.5 * bound, ramp, "p_b") is wave
    assert read_as_measured(wave, wave + 1e-7, pulsing, "x_c") is wave
    rows = read_as_measured(np.stack([wave, wave - bound]), wave, pulsing, "p_b")
    assert rows == pytest.approx(np.stack([wave, wave]), abs=1e-6)


def _drifting_null(default_rig: Rig, p_b_shift: float) -> tuple[float, float]:
    """Held-out cost of the calibrated baseline and the noise's, on a null recording whose
    ``p_b`` zero wanders from ``p_i``'s (a slow creep of 4 kPa and a step of -6 kPa between
    the pulsing levels) and steps by ``p_b_shift`` (Pa) more after the first level."""
    from brake_hil.diagnosis.calibration import calibrate
    from brake_hil.diagnosis.dataset import prepare
    from brake_hil.diagnosis.fitting import Model, fit
    from brake_hil.virtual_rig.excitation import seed_pulsing
    from brake_hil.virtual_rig.simulator import simulate_rig

    run = simulate_rig(default_rig, [], seed_pulsing((1.38e6, 2.76e6), pulsing_s=3.0), seed=5)
    recording = run.as_recording()
    time = recording.time
    later = time > 0.5 * time[-1]
    wander = 4.0e3 * time / time[-1] + (p_b_shift - 6.0e3) * later
    assert recording.bore_pressure is not None
    drifted = replace(recording, bore_pressure=recording.bore_pressure + wander)
    dataset = prepare(drifted, default_rig)
    baseline = fit(Model(calibrate(dataset, default_rig), [], dataset))
    return baseline.held_out_cost, dataset.noise_cost()


def test_a_transducer_zero_wandering_within_its_stability_is_no_evidence(
    default_rig: Rig,
) -> None:
    """Zeros of ``p_i`` and ``p_b`` apart by up to 4 kPa (within 0.1 % of full scale), ten
    times the conditioned channels' noise: the baseline still leaves the noise. Before each pulsing
    window was levelled, such a drift left tens of times the noise's cost and was named
    `unexplained` or taken by an effect."""
    cost, noise = _drifting_null(default_rig, 0.0)
    assert cost < 4.0 * noise


def test_a_zero_shift_past_the_stability_stays_in_the_residual(default_rig: Rig) -> None:
    """A ``p_b`` zero shift of 40 kPa (a transducer that crept under load) is not levelled
    away: the baseline's held-out cost stays far above the noise's."""
    cost, noise = _drifting_null(default_rig, 40.0e3)
    assert cost > 50.0 * noise


def _sine(noise: float, seed: int = 1) -> np.ndarray:
    """3 s of a 5 Hz wave of x_c (m) with white noise, quantised to the probe's 16 bits."""
    sensor = SENSORS["x_c"]
    time = np.arange(0.0, 3.0, 1e-3)
    wave = -1.0e-4 + 8.0e-5 * np.sin(2.0 * np.pi * 5.0 * time)
    noisy = wave + np.random.default_rng(seed).normal(0.0, noise, time.size)
    return np.round((noisy - sensor.low) / sensor.resolution) * sensor.resolution + sensor.low


def test_a_channel_held_at_its_range_end_is_found_and_a_free_one_is_not() -> None:
    """A noisy wave cut at -160 um is held there; the same wave uncut, noisy or noise-free,
    is not (its extreme repeats fewer than ``SATURATED_SAMPLES`` times)."""
    free = _sine(5.0e-8)
    assert held_limits(free) is None
    assert held_limits(_sine(0.0)) is None
    cut = np.maximum(free, -1.6e-4)
    held = held_limits(cut)
    assert held is not None
    assert held.low == pytest.approx(-1.6e-4) and held.high == np.inf
    assert held.share == pytest.approx(np.mean(cut == -1.6e-4))
    assert np.sum(cut == -1.6e-4) >= SATURATED_SAMPLES


def test_a_displacement_probe_held_at_its_range_end_is_no_evidence(default_rig: Rig) -> None:
    """A null recording whose x_c probe saturates at 80 % of the caliper's travel: compared
    as the probe reads, the calibrated baseline leaves less than ``NOISE_EXCESS`` times the
    noise (nothing to name), and the explanation says where the channel is held. Compared
    unclipped it missed by 230 times the noise."""
    from brake_hil.diagnosis.calibration import calibrate
    from brake_hil.diagnosis.dataset import prepare
    from brake_hil.diagnosis.diagnose import held_sentences
    from brake_hil.diagnosis.fitting import Model, fit
    from brake_hil.virtual_rig.excitation import seed_pulsing
    from brake_hil.virtual_rig.simulator import simulate_rig

    run = simulate_rig(default_rig, [], seed_pulsing((1.38e6, 2.76e6), pulsing_s=3.0), seed=5)
    recording = run.as_recording()
    assert recording.caliper_displacement is not None
    end = 0.8 * float(np.min(recording.caliper_displacement))
    held = replace(recording, caliper_displacement=np.maximum(recording.caliper_displacement, end))
    dataset = prepare(held, default_rig)
    assert set(dataset.held) == {"x_c"}  # not p_b, held at gauge zero while idle only
    assert dataset.held["x_c"].low == pytest.approx(end) and dataset.held["x_c"].share > 0.01
    baseline = fit(Model(calibrate(dataset, default_rig), [], dataset))
    assert baseline.held_out_cost < NOISE_EXCESS * dataset.noise_cost()
    (sentence,) = held_sentences(dataset.held)
    assert sentence.startswith(f"x_c is held at {1e6 * end:.1f} um in ")
