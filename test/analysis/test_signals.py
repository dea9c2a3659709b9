"""Tests of brake_hil.analysis.signals: filters, the seed's Table 1 and Tables 4-5 metrics."""

from __future__ import annotations

from collections.abc import Callable
import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq  # type: ignore[import-untyped]

from brake_hil.analysis import signals
from brake_hil.errors import SignalError
from brake_hil.types import FloatArray

RATE_HZ = 1000.0
OMEGA = 2.0 * math.pi * 5.0  # rad/s, the seed's 5 Hz excitation
PERIOD_S = 0.2


def _time(duration_s: float, rate_hz: float = RATE_HZ) -> FloatArray:
    return np.arange(round(duration_s * rate_hz)) / rate_hz


def _amplitude_and_phase(
    values: FloatArray, time: FloatArray, freq_hz: float
) -> tuple[float, float]:
    """Amplitude and phase (rad) of ``values`` as ``A sin(2 pi f t + phase)``, whole periods."""
    phasor = 2.0 * np.mean(values * np.exp(-2j * math.pi * freq_hz * time))
    return float(abs(phasor)), float(np.angle(phasor)) + 0.5 * math.pi


def _interior(values: FloatArray) -> FloatArray:
    """Drop 1 s at each end (filter edge effects)."""
    return values[1000:-1000]


# --------------------------------------------------------------------------- filters


def test_lowpass_keeps_the_5_hz_amplitude_and_phase() -> None:
    time = _time(4.0)
    sine = np.sin(OMEGA * time + 0.3)
    filtered = signals.lowpass(sine, RATE_HZ)
    amplitude, phase = _amplitude_and_phase(_interior(filtered), _interior(time), 5.0)
    assert amplitude == pytest.approx(1.0, rel=1e-3)
    assert phase == pytest.approx(0.3, abs=1e-4)  # zero-phase: a causal filter lags ~30 mrad
    assert np.max(np.abs(_interior(filtered - sine))) < 1e-3


def test_lowpass_attenuates_100_hz_by_more_than_40_db() -> None:
    time = _time(4.0)
    filtered = signals.lowpass(np.sin(2.0 * math.pi * 100.0 * time), RATE_HZ)
    assert np.max(np.abs(_interior(filtered))) < 0.01


def test_lowpass_is_a_third_order_butterworth_applied_twice() -> None:
    # |H|^2 of a digital (bilinear) 3rd-order Butterworth: 1/2 at the 30 Hz cut-off,
    # 1/(1 + r^6) at 60 Hz with r = tan(pi 60/fs) / tan(pi 30/fs), the prewarped ratio
    ratio = math.tan(math.pi * 60.0 / RATE_HZ) / math.tan(math.pi * 30.0 / RATE_HZ)
    time = _time(4.0)
    at_cutoff = signals.lowpass(np.sin(2.0 * math.pi * 30.0 * time), RATE_HZ)
    at_double = signals.lowpass(np.sin(2.0 * math.pi * 60.0 * time), RATE_HZ)
    assert _amplitude_and_phase(_interior(at_cutoff), _interior(time), 30.0)[0] == pytest.approx(
        0.5, rel=0.01
    )
    assert _amplitude_and_phase(_interior(at_double), _interior(time), 60.0)[0] == pytest.approx(
        1.0 / (1.0 + ratio**6), rel=0.01
    )


def test_bandpass_keeps_only_the_fundamental_without_phase_shift() -> None:
    time = _time(8.0)
    mixed = 0.9e6 + np.sin(OMEGA * time + 0.3) + 0.5 * np.sin(2.0 * OMEGA * time)
    filtered = signals.bandpass(mixed, RATE_HZ)
    inner, inner_time = filtered[2000:-2000], time[2000:-2000]
    amplitude, phase = _amplitude_and_phase(inner, inner_time, 5.0)
    assert amplitude == pytest.approx(1.0, rel=0.01)
    assert phase == pytest.approx(0.3, abs=1e-3)
    assert _amplitude_and_phase(inner, inner_time, 10.0)[0] < 0.5 * 1e-3  # 10 Hz: ~ -70 dB
    assert abs(float(np.mean(inner))) < 1e-3  # the 0.9 MPa mean is gone


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: signals.lowpass(np.ones(100), 50.0), "Nyquist"),
        (lambda: signals.lowpass(np.ones(5), RATE_HZ), "samples"),
        (lambda: signals.lowpass(np.array([1.0, np.nan] * 50), RATE_HZ), "non-finite"),
        (lambda: signals.bandpass(np.ones(1000), RATE_HZ, 6.0, 4.0), "low < high"),
        (lambda: signals.lowpass(np.ones((10, 10)), RATE_HZ), "1-D"),
    ],
)
def test_filters_refuse_unusable_input(call: Callable[[], object], match: str) -> None:
    with pytest.raises(SignalError, match=match):
        call()


# --------------------------------------------------------------------------- Table 1


def test_pure_sine_has_all_its_energy_at_the_fundamental() -> None:
    shares = signals.harmonic_energy_shares(np.sin(OMEGA * _time(4.0) + 0.7), RATE_HZ)
    assert shares.shape == (5,)
    assert shares[0] > 99.99
    assert float(shares.sum()) == pytest.approx(100.0)


def test_known_mix_gives_the_energy_ratio_of_its_amplitudes() -> None:
    time = _time(4.0)
    mix = np.sin(OMEGA * time) + 0.1 * np.sin(2.0 * OMEGA * time + 1.0)
    shares = signals.harmonic_energy_shares(mix, RATE_HZ)
    np.testing.assert_allclose(shares[:2], [100.0 / 1.01, 1.0 / 1.01], rtol=1e-9)
    assert np.all(shares[2:] < 1e-9)


def test_shares_ignore_the_mean_and_a_partial_last_period() -> None:
    # 3957 samples: 19 whole periods and a fraction; without trimming, the large mean and
    # the partial period would leak into every harmonic
    time = np.arange(3957) / RATE_HZ
    mix = 1.38e6 + np.sin(OMEGA * time) + 0.1 * np.sin(3.0 * OMEGA * time)
    shares = signals.harmonic_energy_shares(mix, RATE_HZ)
    np.testing.assert_allclose(shares, [100.0 / 1.01, 0.0, 1.0 / 1.01, 0.0, 0.0], atol=1e-6)


def test_shares_hold_when_a_period_is_not_a_whole_number_of_samples() -> None:
    time = np.arange(3993) / 1024.0  # 204.8 samples per period
    shares = signals.harmonic_energy_shares(np.sin(OMEGA * time + 0.4), 1024.0)
    assert shares[0] > 99.99


def test_shares_refuse_a_constant_or_too_short_signal() -> None:
    with pytest.raises(SignalError, match="no energy"):
        signals.harmonic_energy_shares(np.full(1000, 2.0), RATE_HZ)
    with pytest.raises(SignalError, match="whole periods"):
        signals.harmonic_energy_shares(np.sin(OMEGA * _time(0.5)), RATE_HZ)


# --------------------------------------------------------------------------- peak to peak


def test_peak_to_peak_is_max_minus_min() -> None:
    assert signals.peak_to_peak([3.0, -1.5, 2.0]) == 4.5


def test_per_cycle_peak_to_peak_ignores_drift_and_one_disturbed_cycle() -> None:
    time = _time(2.0)
    values = np.sin(OMEGA * time) + 0.5 * time  # mean drifts by 1.0 over the window
    values[705] += 10.0  # one spike
    assert signals.peak_to_peak(values) > 10.0
    # within a cycle the drift moves the peaks by at most 0.5 * 0.2 = 0.1
    assert 1.9 < signals.per_cycle_peak_to_peak(values, time) < 2.1


def test_per_cycle_peak_to_peak_ignores_a_trailing_partial_cycle() -> None:
    time = _time(0.5)  # two whole cycles and half of one
    values = np.sin(OMEGA * time) * np.where(time >= 0.4, 5.0, 1.0)
    assert signals.per_cycle_peak_to_peak(values, time) == pytest.approx(2.0, rel=1e-9)
    with pytest.raises(SignalError, match="whole cycle"):
        signals.per_cycle_peak_to_peak(values[:150], time[:150])


# --------------------------------------------------------------------------- time offsets


@pytest.mark.parametrize("delay_s", [0.007, 0.0073, -0.007])
def test_lagging_prediction_gives_negative_tau_on_both_edges(delay_s: float) -> None:
    time = _time(2.0)
    measured = np.sin(OMEGA * time)
    predicted = np.sin(OMEGA * (time - delay_s))  # crosses delay_s after the measurement
    tau_1, tau_2, tau = signals.mean_crossing_offsets(predicted, measured, time)
    assert tau_1 == pytest.approx(-delay_s, abs=1e-4)
    assert tau_2 == pytest.approx(-delay_s, abs=1e-4)
    assert tau == pytest.approx(-delay_s, abs=1e-4)


def test_falling_and_rising_offsets_are_told_apart() -> None:
    # sin(theta) + a cos(2 theta) crosses zero early on the rising edge, late on the falling
    a = 0.1
    time = _time(2.0)
    measured = np.sin(OMEGA * time)
    predicted = np.sin(OMEGA * time) + a * np.cos(2.0 * OMEGA * time)

    def shape(theta: float) -> float:
        return math.sin(theta) + a * math.cos(2.0 * theta)

    rising_lead_s = -float(brentq(shape, -0.5, 0.5)) / OMEGA
    falling_lead_s = (math.pi - float(brentq(shape, math.pi - 0.5, math.pi + 0.5))) / OMEGA
    offsets = signals.mean_crossing_offsets(predicted, measured, time)
    assert rising_lead_s > 0.003 > -0.003 > falling_lead_s
    assert offsets.tau_1_s == pytest.approx(falling_lead_s, abs=1e-4)
    assert offsets.tau_2_s == pytest.approx(rising_lead_s, abs=1e-4)
    assert offsets.tau_s == pytest.approx(0.5 * (falling_lead_s + rising_lead_s), abs=1e-4)


def test_each_signal_crosses_its_own_mean() -> None:
    time = _time(2.0)
    measured = -20e-6 + 5e-6 * np.sin(OMEGA * time)  # x_c: m, negative under load
    predicted = -35e-6 + 9e-6 * np.sin(OMEGA * (time + 0.004))  # offset, gain, leads 4 ms
    offsets = signals.mean_crossing_offsets(predicted, measured, time)
    assert offsets.tau_s == pytest.approx(0.004, abs=1e-4)


def test_noise_near_the_mean_adds_no_crossings() -> None:
    time = _time(4.0)
    rng = np.random.default_rng(7)
    measured = np.sin(OMEGA * time) + 0.05 * rng.standard_normal(time.size)
    predicted = np.sin(OMEGA * (time - 0.007)) + 0.05 * rng.standard_normal(time.size)
    offsets = signals.mean_crossing_offsets(predicted, measured, time)
    assert offsets.tau_1_s == pytest.approx(-0.007, abs=5e-4)
    assert offsets.tau_2_s == pytest.approx(-0.007, abs=5e-4)


def test_offsets_refuse_signals_without_crossings() -> None:
    time = _time(1.0)
    with pytest.raises(SignalError, match="crossing"):
        signals.mean_crossing_offsets(np.full(time.size, 3.0), np.sin(OMEGA * time), time)
    with pytest.raises(SignalError, match="same number"):
        signals.mean_crossing_offsets(np.zeros(10), np.zeros(11), np.arange(10.0))
    with pytest.raises(SignalError, match="increasing"):
        signals.mean_crossing_offsets(np.zeros(3), np.zeros(3), [0.0, 0.2, 0.1])


# --------------------------------------------------------------------------- NRMSE, metrics


def test_nrmse_is_zero_for_a_perfect_prediction_and_offset_over_range() -> None:
    time = _time(1.0)
    measured = 0.9e6 + 0.3e6 * np.sin(OMEGA * time)  # Pa, peak-to-peak 0.6 MPa
    assert signals.nrmse(measured, measured) == 0.0
    assert signals.nrmse(measured + 0.03e6, measured) == pytest.approx(0.05, rel=1e-9)
    with pytest.raises(SignalError, match="constant"):
        signals.nrmse(measured, np.full(time.size, 1.0))


def test_cycle_metrics_of_a_scaled_delayed_copy() -> None:
    time = _time(2.0)
    measured = 1.26e3 + 0.6e3 * np.sin(OMEGA * time)  # F_k, N
    predicted = 1.26e3 + 0.891 * 0.6e3 * np.sin(OMEGA * (time - 0.004))
    metrics = signals.cycle_metrics(predicted, measured, time)
    assert metrics.ptp_ratio_pct == pytest.approx(89.1, abs=0.01)
    assert metrics.tau_over_T_pct == pytest.approx(-2.0, abs=0.05)  # 4 ms of 200 ms, lagging
    assert metrics.cycles == 10
    expected_nrmse = math.sqrt(np.mean((predicted - measured) ** 2)) / 1.2e3
    assert metrics.nrmse == pytest.approx(expected_nrmse, rel=1e-3)
    as_json = json.loads(json.dumps(metrics.as_dict()))
    assert {"ptp_ratio_pct", "tau_over_T_pct", "nrmse", "tau_1_s", "tau_2_s"} <= set(as_json)


def test_ptp_ratio_of_a_scaled_copy_equals_the_scale() -> None:
    time = _time(2.0)
    measured = np.sin(OMEGA * time) + 0.05 * np.sin(3.0 * OMEGA * time)
    metrics = signals.cycle_metrics(1.026 * measured, measured, time)
    assert metrics.ptp_ratio_pct == pytest.approx(102.6, rel=1e-9)
    assert metrics.tau_s == pytest.approx(0.0, abs=1e-9)


# --------------------------------------------------------------------------- segments


def _pulsing(
    time: FloatArray, start_s: float, stop_s: float, max_pa: float, ptp_pa: float
) -> FloatArray:
    """The seed's excitation: at ``max_pa``, the solenoid dips the pressure at 5 Hz."""
    active = (time >= start_s) & (time < stop_s)
    dip = 0.5 * ptp_pa * (1.0 - np.cos(OMEGA * (time - start_s)))
    return np.where(active, max_pa - dip, 0.0)


def _noisy(values: FloatArray, seed: int = 3) -> FloatArray:
    return values + 2e3 * np.random.default_rng(seed).standard_normal(values.size)


def _assert_segment_within(
    segment: tuple[float, float], time: FloatArray, on_s: float, off_s: float
) -> None:
    start, end = segment
    assert on_s + 1.0 <= start <= on_s + 1.0 + 2 * PERIOD_S  # settle_s = 1 s after onset
    assert off_s - 3 * PERIOD_S <= end <= off_s
    cycles = (end - start) / PERIOD_S
    assert cycles == pytest.approx(round(cycles), abs=1e-9)
    assert np.min(np.abs(time - start)) < 1e-12  # starts on a sample
    window = signals.segment_slice(time, start, end)
    assert window.stop - window.start == round(cycles) * 200  # 200 samples per period


def test_steady_segment_after_a_ramp() -> None:
    time = _time(12.0)
    ramp = np.where(time < 2.0, 1.38e6 * time / 2.0, 0.0)
    pressure = _noisy(ramp + _pulsing(time, 2.0, 12.0, 1.38e6, 0.6e6))
    segments = signals.steady_segments(time, pressure, RATE_HZ)
    assert len(segments) == 1
    _assert_segment_within(segments[0], time, 2.0, 12.0)


def test_three_steady_segments_separated_by_ramps_and_pauses() -> None:
    time = _time(24.0)
    pressure = (
        np.interp(
            time, [0, 2, 8, 9, 16, 17, 23, 24], [0, 1.38, 1.38, 2.07, 2.07, 2.76, 2.76, 2.76]
        )
        * 1e6
    )
    levels = [(2.0, 8.0, 1.38e6, 0.6e6), (9.0, 15.0, 2.07e6, 0.9e6), (17.0, 23.0, 2.76e6, 1.2e6)]
    for on_s, off_s, max_pa, ptp_pa in levels:
        active = (time >= on_s) & (time < off_s)
        pressure = np.where(active, _pulsing(time, on_s, off_s, max_pa, ptp_pa), pressure)
    segments = signals.steady_segments(time, _noisy(pressure), RATE_HZ)
    assert len(segments) == 3
    for segment, (on_s, off_s, _, _) in zip(segments, levels):
        _assert_segment_within(segment, time, on_s, off_s)


def test_pulsing_while_the_pressure_still_ramps_is_not_steady() -> None:
    time = _time(10.0)
    ramp = np.minimum(time / 4.0, 1.0) * 2.76e6  # 0.14 MPa per period, under 0.6 MPa pulses
    dip = 0.3e6 * (1.0 - np.cos(OMEGA * time))
    segments = signals.steady_segments(time, _noisy(ramp - dip), RATE_HZ)
    assert len(segments) == 1
    _assert_segment_within(segments[0], time, 4.0, 10.0)


def test_a_pure_ramp_has_no_steady_segment() -> None:
    time = _time(10.0)
    with pytest.raises(SignalError, match="No steady segment"):
        signals.steady_segments(time, _noisy(2.76e6 * time / 10.0), RATE_HZ)


def test_a_constant_pressure_has_no_steady_segment() -> None:
    time = _time(10.0)
    with pytest.raises(SignalError, match="No steady segment"):
        signals.steady_segments(time, _noisy(np.full(time.size, 1.38e6)), RATE_HZ)


def test_pulsing_too_short_to_settle_is_refused_with_its_length() -> None:
    time = _time(6.0)
    ramp = np.where(time < 4.5, 1.38e6 * time / 4.5, 0.0)
    pressure = _noisy(ramp + _pulsing(time, 4.5, 6.0, 1.38e6, 0.6e6))
    with pytest.raises(SignalError, match="shorter than"):
        signals.steady_segments(time, pressure, RATE_HZ)


def test_whole_cycles_trims_the_end_to_whole_periods() -> None:
    assert signals.whole_cycles(1.0, 2.05) == pytest.approx((1.0, 2.0))
    assert signals.whole_cycles(0.0, 0.6 - 1e-12) == pytest.approx((0.0, 0.6))
    with pytest.raises(SignalError, match="shorter than one period"):
        signals.whole_cycles(0.0, 0.1)
