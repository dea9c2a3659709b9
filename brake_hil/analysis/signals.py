"""Signal conditioning and the seed's comparison metrics (numpy/scipy only).

The seed (Liette, Dreyer, Singh 2012) conditions every signal with a third-order zero-phase
Butterworth low-pass at 30 Hz, estimates damping on a 4-6 Hz band-pass, and reports:

* Table 1: the share of energy spectral density at the first five harmonics of 5 Hz
  (:func:`harmonic_energy_shares`);
* Tables 4-5: the predicted-to-measured peak-to-peak ratio (:func:`cycle_metrics`) and the
  time offset ``tau`` where the signals cross their mean, ``tau_1`` on the falling edge,
  ``tau_2`` on the rising edge, ``tau = (tau_1 + tau_2) / 2``, positive when the prediction
  crosses first (:func:`mean_crossing_offsets`), given as ``tau / T`` with ``T`` = 200 ms.

:func:`steady_segments` finds the steady 5 Hz pulsing that the seed analyses ("steady state
portion only") in a recording that also holds ramps and pauses.

Conventions: signals are 1-D float arrays in any consistent unit (Pa, N, m); times are in
seconds; a segment ``(start_s, end_s)`` is the half-open interval ``start_s <= t < end_s``
(use :func:`segment_slice` to cut it out of sampled data). Every function refuses unusable
input (wrong shape, NaN, too short, no oscillation) with :class:`~brake_hil.errors.SignalError`.

The whole cycles of a signal live in :mod:`brake_hil.analysis.cycles`, the Tables 4-5
metrics in :mod:`brake_hil.analysis.cycle_metrics`; both are re-exported here.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from brake_hil.analysis.cycle_metrics import (
    ChannelMetrics,
    CrossingOffsets,
    cycle_metrics,
    mean_crossing_offsets,
    nrmse,
)
from brake_hil.analysis.cycles import (
    EXCITATION_PERIOD_S,
    as_same_length,
    as_signal,
    as_time,
    check_positive,
    peak_to_peak,
    per_cycle_peak_to_peak,
    segment_slice,
    whole_cycles,
)
from brake_hil.errors import NoSteadyPulsingError, SignalError
from brake_hil.types import FloatArray

__all__ = [
    "EXCITATION_PERIOD_S",
    "ChannelMetrics",
    "CrossingOffsets",
    "bandpass",
    "cycle_metrics",
    "harmonic_energy_shares",
    "harmonic_phasor",
    "lowpass",
    "mean_crossing_offsets",
    "nrmse",
    "peak_to_peak",
    "per_cycle_peak_to_peak",
    "segment_slice",
    "steady_segments",
    "whole_cycles",
]

# steady_segments thresholds (see its docstring).
_MIN_FUNDAMENTAL_SHARE = 0.7
_MAX_DRIFT_PER_PERIOD = 0.1
_MIN_RELATIVE_AMPLITUDE = 0.1
_MIN_SEGMENT_PERIODS = 3


# --------------------------------------------------------------------------- filters


def _zero_phase(
    values: npt.ArrayLike,
    sample_rate_hz: float,
    cutoff_hz: float | tuple[float, float],
    btype: str,
    order: int,
) -> FloatArray:
    """Butterworth ``btype`` filter applied forward and backward (second-order sections)."""
    check_positive(sample_rate_hz, "sample_rate_hz")
    if order < 1:
        msg = f"Filter order must be at least 1, got {order}."
        raise SignalError(msg)
    edges = cutoff_hz if isinstance(cutoff_hz, tuple) else (cutoff_hz,)
    nyquist_hz = 0.5 * sample_rate_hz
    for edge in edges:
        if not 0.0 < edge < nyquist_hz:
            msg = (
                f"Cut-off {edge} Hz must lie between 0 and the Nyquist frequency "
                f"{nyquist_hz} Hz (sample rate {sample_rate_hz} Hz)."
            )
            raise SignalError(msg)
    if len(edges) == 2 and not edges[0] < edges[1]:
        msg = f"Band-pass edges must satisfy low < high, got {edges[0]} and {edges[1]} Hz."
        raise SignalError(msg)
    from scipy import signal as sps  # type: ignore[import-untyped]  # 1-2 s: not at import

    sos = sps.butter(order, cutoff_hz, btype=btype, fs=sample_rate_hz, output="sos")
    # sosfiltfilt pads with an odd extension of this many samples (scipy's default).
    taps = 2 * sos.shape[0] + 1 - min(int(np.sum(sos[:, 2] == 0)), int(np.sum(sos[:, 5] == 0)))
    array = as_signal(values, "signal", min_samples=3 * taps + 1)
    filtered: FloatArray = np.asarray(sps.sosfiltfilt(sos, array), dtype=np.float64)
    return filtered


def lowpass(
    signal: npt.ArrayLike,
    sample_rate_hz: float,
    cutoff_hz: float = 30.0,
    order: int = 3,
) -> FloatArray:
    """Zero-phase Butterworth low-pass: the seed's initial signal conditioning.

    A Butterworth filter of ``order`` (second-order sections) is run forward and backward
    (``scipy.signal.sosfiltfilt``), as MATLAB's ``filtfilt`` does: no phase shift, magnitude
    response squared (-6 dB at ``cutoff_hz``, roll-off of ``2 * order`` x 20 dB/decade).
    The seed: "third-order zero-phase Butterworth low-pass filter with a cutoff frequency of
    30 Hz".

    Args:
        signal: Samples, uniformly spaced (any unit; the output has the same unit).
        sample_rate_hz: Sample rate (Hz).
        cutoff_hz: Cut-off frequency of the Butterworth design (Hz), below the Nyquist frequency.
        order: Order of the Butterworth design (applied twice).

    Raises:
        SignalError: NaN samples, a cut-off outside (0, Nyquist), or a signal too short to pad.
    """
    return _zero_phase(signal, sample_rate_hz, cutoff_hz, "lowpass", order)


def bandpass(
    signal: npt.ArrayLike,
    sample_rate_hz: float,
    low_hz: float = 4.0,
    high_hz: float = 6.0,
    order: int = 3,
) -> FloatArray:
    """Zero-phase Butterworth band-pass: the seed's 4-6 Hz parameter-estimation filter.

    Run forward and backward like :func:`lowpass`. The seed passes the dynamic ``F_k`` and
    ``x_c`` through it to keep only the 5 Hz fundamental before building the hysteresis loop
    (eq. 1). A 2 Hz wide band rings for about a second: discard about 1 s at each end of the
    filtered signal (or analyse a steady segment well inside it).

    Args:
        signal: Samples, uniformly spaced (any unit; the output has the same unit).
        sample_rate_hz: Sample rate (Hz).
        low_hz: Lower band edge of the Butterworth design (Hz),
            ``0 < low_hz < high_hz < Nyquist``.
        high_hz: Upper band edge of the Butterworth design (Hz).
        order: Order of the Butterworth prototype (the band-pass has twice as many poles).

    Raises:
        SignalError: NaN samples, band edges out of order or range, or a signal too short to pad.
    """
    return _zero_phase(signal, sample_rate_hz, (low_hz, high_hz), "bandpass", order)


# --------------------------------------------------------------------------- spectra


def harmonic_energy_shares(
    signal: npt.ArrayLike,
    sample_rate_hz: float,
    fundamental_hz: float = 5.0,
    count: int = 5,
    half_width_bins: int = 1,
) -> FloatArray:
    """Share (%) of energy spectral density at each of the first harmonics (seed Table 1).

    The mean is removed and the signal is trimmed at its end to the largest whole number of
    fundamental periods ``m`` that fits, so that harmonic ``k`` falls on FFT bin ``k * m``
    (exactly when a period is a whole number of samples, e.g. 200 samples at 1 kHz and 5 Hz;
    otherwise within a small fraction of a bin). The energy of harmonic ``k`` is the sum of
    ``|X|^2`` over bins ``k * m - half_width_bins`` to ``k * m + half_width_bins``; the side
    bins hold the leakage of a fundamental that is slightly off (a sample rate that is not
    a multiple of the excitation, a solenoid running at 4.98 Hz) and almost nothing
    otherwise. Shares are normalised to sum to 100 over the ``count`` harmonics, as in the
    seed (its 5-25 Hz columns sum to about 100 %).

    Args:
        signal: Samples of a steady periodic segment, uniformly spaced (any unit).
        sample_rate_hz: Sample rate (Hz).
        fundamental_hz: Excitation frequency (Hz); the seed's is 5 Hz.
        count: Number of harmonics (fundamental included); the seed uses 5 (5-25 Hz).
        half_width_bins: Bins summed on each side of each harmonic's bin (0 reads the single bin).

    Returns:
        ``count`` shares (%), fundamental first, summing to 100.

    Raises:
        SignalError: Fewer whole periods than needed to separate the harmonics, a harmonic above
            the Nyquist frequency, or no energy at the harmonics.
    """
    check_positive(sample_rate_hz, "sample_rate_hz")
    check_positive(fundamental_hz, "fundamental_hz")
    if count < 1 or half_width_bins < 0:
        msg = f"count must be >= 1 and half_width_bins >= 0, got {count}, {half_width_bins}."
        raise SignalError(msg)
    if count * fundamental_hz >= 0.5 * sample_rate_hz:
        msg = (
            f"Harmonic {count} of {fundamental_hz} Hz is at or above the Nyquist frequency "
            f"of {sample_rate_hz} Hz sampling."
        )
        raise SignalError(msg)
    array = as_signal(signal, "signal")
    samples_per_period = sample_rate_hz / fundamental_hz
    periods = int(array.size / samples_per_period + 1e-9)
    while periods > 0 and round(periods * samples_per_period) > array.size:
        periods -= 1
    min_periods = 2 * half_width_bins + 1
    if periods < min_periods:
        msg = (
            f"Signal of {array.size} samples holds {periods} whole periods of "
            f"{fundamental_hz} Hz; at least {min_periods} are needed."
        )
        raise SignalError(msg)
    trimmed = array[: round(periods * samples_per_period)]
    spectrum = np.abs(np.fft.rfft(trimmed - trimmed.mean())) ** 2
    energies = np.array(
        [
            spectrum[k * periods - half_width_bins : k * periods + half_width_bins + 1].sum()
            for k in range(1, count + 1)
        ],
        dtype=np.float64,
    )
    total = float(energies.sum())
    if not total > 0.0:
        msg = f"Signal has no energy at the harmonics of {fundamental_hz} Hz."
        raise SignalError(msg)
    shares: FloatArray = 100.0 * energies / total
    return shares


def harmonic_phasor(signal: npt.ArrayLike, time_s: npt.ArrayLike, frequency_hz: float) -> complex:
    """Complex amplitude ``X`` of the ``frequency_hz`` component: ``x(t) ~ Re(X e^{jwt})``.

    Least-squares fit of ``offset + drift t + a cos(wt) + b sin(wt)`` over the samples
    (pass whole cycles), ``X = a - j b``. It is what the seed's 4-6 Hz band-pass isolates,
    in the limit of a narrow band, without the filter's transients at the segment's ends.
    """
    values, time = as_same_length({"signal": signal, "time_s": time_s})
    time = as_time(time)
    check_positive(frequency_hz, "frequency_hz")
    phase = 2.0 * np.pi * frequency_hz * time
    centred = time - time.mean()
    basis = np.column_stack([np.ones_like(time), centred, np.cos(phase), np.sin(phase)])
    coefficients, *_ = np.linalg.lstsq(basis, values, rcond=None)
    return complex(coefficients[2], -coefficients[3])


# --------------------------------------------------------------------------- segments


def _centred_moving_mean(values: FloatArray, window: int) -> FloatArray:
    """Mean over ``window`` samples centred on each sample; NaN where it does not fit."""
    sums = np.concatenate(([0.0], np.cumsum(values)))
    valid = (sums[window:] - sums[:-window]) / window
    out = np.full(values.size, np.nan)
    start = window // 2
    out[start : start + valid.size] = valid
    return out


def steady_segments(
    time_s: npt.ArrayLike,
    pressure: npt.ArrayLike,
    sample_rate_hz: float,
    period_s: float = EXCITATION_PERIOD_S,
    settle_s: float = 1.0,
    min_duration_s: float = 1.0,
) -> list[tuple[float, float]]:
    """Find the steady pulsing segments ``(start_s, end_s)`` (s) of a recording.

    A recording may hold a ramp then pulsing at one maximum pressure, or several pulsing
    segments (1.38, 2.07, 2.76 MPa in the seed) separated by ramps or pauses. After the
    30 Hz :func:`lowpass`, three quantities are computed over a sliding window of one
    period ``T``: the mean, the amplitude ``A`` of the ``1 / T`` component (a lock-in
    estimate), and the variance. A sample is steady when, in the window centred on it,

    * the ``1 / T`` component carries at least 70 % of the variance (``A^2 / 2 >= 0.7 var``;
      a sine gives 1, a square wave 0.81, a ramp 0.61, noise about 0.2): the oscillation is
      present and is the excitation;
    * the mean changes by at most 10 % of the peak-to-peak ``2 A`` over one period (a ramp
      changes by ``pi / 2`` times it): the operating point is steady;
    * ``A`` is at least 10 % of the largest such amplitude in the recording.

    Each run of steady samples becomes one segment: ``settle_s`` is dropped after its first
    steady sample (the windows already exclude about one period before it), its end is
    trimmed to a whole number of periods (:func:`whole_cycles`), and it is kept when it
    still lasts ``min_duration_s`` and at least three periods. Segment starts fall on a
    sample; cut segments out with :func:`segment_slice`.

    Args:
        time_s: Sample times (s), strictly increasing.
        pressure: The pressure that carries the excitation (Pa), ``p_i`` or ``p_b``; raw or
            filtered.
        sample_rate_hz: Sample rate (Hz), at least 60 Hz for the 30 Hz low-pass.
        period_s: Excitation period ``T`` (s); 0.2 s in the seed.
        settle_s: Transient dropped at the start of each segment (s).
        min_duration_s: Shortest segment kept, after settling and trimming (s).

    Raises:
        SignalError: Bad input, a recording shorter than three periods, or no steady segment (the
            message says which condition failed).
    """
    values, time = as_same_length({"pressure": pressure, "time_s": time_s})
    time = as_time(time)
    window = _steady_window(values.size, period_s, sample_rate_hz, settle_s, min_duration_s)
    steady = _steady_samples(values, time, sample_rate_hz, period_s, window)
    return _steady_runs(time, steady, period_s, settle_s, min_duration_s)


def _steady_window(
    samples: int, period_s: float, sample_rate_hz: float, settle_s: float, min_duration_s: float
) -> int:
    """Samples in one period; refuse bad settings or a recording shorter than 3 periods."""
    check_positive(period_s, "period_s")
    check_positive(sample_rate_hz, "sample_rate_hz")
    if settle_s < 0.0 or min_duration_s < 0.0:
        msg = f"settle_s and min_duration_s must be >= 0, got {settle_s}, {min_duration_s}."
        raise SignalError(msg)
    window = round(period_s * sample_rate_hz)
    if window < 4:
        msg = f"A period of {period_s} s at {sample_rate_hz} Hz holds fewer than 4 samples."
        raise SignalError(msg)
    if samples < _MIN_SEGMENT_PERIODS * window:
        msg = (
            f"Recording of {samples} samples is shorter than {_MIN_SEGMENT_PERIODS} "
            f"periods of {period_s} s: no steady segment can be found."
        )
        raise NoSteadyPulsingError(msg)
    return window


def _steady_samples(
    values: FloatArray, time: FloatArray, sample_rate_hz: float, period_s: float, window: int
) -> npt.NDArray[np.bool_]:
    """Which samples are steady pulsing (the three conditions of :func:`steady_segments`)."""
    conditioned = lowpass(values, sample_rate_hz)
    conditioned = conditioned - np.median(conditioned)
    phase = 2.0 * np.pi * (time - time[0]) / period_s
    mean = _centred_moving_mean(conditioned, window)
    variance = _centred_moving_mean(conditioned**2, window) - mean**2
    in_phase = _centred_moving_mean(conditioned * np.cos(phase), window)
    quadrature = _centred_moving_mean(conditioned * np.sin(phase), window)
    amplitude = 2.0 * np.hypot(in_phase, quadrature)

    # change of the moving mean over one period, centred on each sample
    ahead, behind = window // 2, window - window // 2
    drift = np.full(values.size, np.nan)
    drift[behind : values.size - ahead] = np.abs(
        mean[behind + ahead :] - mean[: values.size - ahead - behind]
    )

    with np.errstate(invalid="ignore", divide="ignore"):
        share = 0.5 * amplitude**2 / np.maximum(variance, np.finfo(float).tiny)
        periodic = share >= _MIN_FUNDAMENTAL_SHARE
        settled = drift <= _MAX_DRIFT_PER_PERIOD * 2.0 * amplitude
    candidate = periodic & settled
    if not np.any(periodic):
        msg = f"No steady segment: the recording never oscillates at {1.0 / period_s:g} Hz."
        raise NoSteadyPulsingError(msg)
    if not np.any(candidate):
        msg = (
            f"No steady segment: the {1.0 / period_s:g} Hz oscillation never holds a steady "
            "mean (ramping throughout)."
        )
        raise NoSteadyPulsingError(msg)
    steady: npt.NDArray[np.bool_] = candidate & (
        amplitude >= _MIN_RELATIVE_AMPLITUDE * np.nanmax(amplitude[candidate])
    )
    return steady


def _steady_runs(
    time: FloatArray,
    steady: npt.NDArray[np.bool_],
    period_s: float,
    settle_s: float,
    min_duration_s: float,
) -> list[tuple[float, float]]:
    """Each run of steady samples, settled and trimmed to whole periods, when long enough."""
    edges = np.diff(np.concatenate(([0], steady.astype(np.int8), [0])))
    run_starts = np.flatnonzero(edges == 1)
    run_ends = np.flatnonzero(edges == -1) - 1  # inclusive
    min_periods = max(_MIN_SEGMENT_PERIODS, math.ceil(min_duration_s / period_s - 1e-9))
    segments: list[tuple[float, float]] = []
    longest = 0.0
    for first, last in zip(run_starts, run_ends):
        start_index = int(np.searchsorted(time, time[first] + settle_s - 1e-9, side="left"))
        if start_index > last:
            continue
        start, end = float(time[start_index]), float(time[last])
        longest = max(longest, end - start)
        cycles = math.floor((end - start) / period_s + 1e-9)
        if cycles >= min_periods:
            segments.append(whole_cycles(start, end, period_s))
    if not segments:
        msg = (
            f"No steady segment: the longest steady pulsing lasts {longest:.3g} s after "
            f"{settle_s:g} s settling, shorter than {min_periods} periods of {period_s} s."
        )
        raise NoSteadyPulsingError(msg)
    return segments
