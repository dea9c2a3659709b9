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
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from brake_hil.errors import NoSteadyPulsingError, SignalError
from brake_hil.types import FloatArray, IndexArray

EXCITATION_PERIOD_S = 0.2
"""Period ``T`` of the seed's 5 Hz excitation (s)."""

# Schmitt-trigger band around the mean used to count one crossing per edge, as a fraction of
# the signal's half range (1st to 99th percentile): noise cannot add crossings.
_CROSSING_HYSTERESIS = 0.1

# steady_segments thresholds (see its docstring).
_MIN_FUNDAMENTAL_SHARE = 0.7
_MAX_DRIFT_PER_PERIOD = 0.1
_MIN_RELATIVE_AMPLITUDE = 0.1
_MIN_SEGMENT_PERIODS = 3


# --------------------------------------------------------------------------- validation


def _as_signal(values: npt.ArrayLike, name: str, min_samples: int = 2) -> FloatArray:
    """Return ``values`` as a finite 1-D float64 array, or raise SignalError naming it."""
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 1:
        msg = f"{name} must be a 1-D array, got shape {array.shape}."
        raise SignalError(msg)
    if array.size < min_samples:
        msg = f"{name} has {array.size} samples, at least {min_samples} are needed."
        raise SignalError(msg)
    if not np.all(np.isfinite(array)):
        bad = int(np.count_nonzero(~np.isfinite(array)))
        msg = f"{name} holds {bad} non-finite samples (NaN or inf)."
        raise SignalError(msg)
    return array


def _as_same_length(named: dict[str, npt.ArrayLike]) -> list[FloatArray]:
    """Convert several signals and check that they have one length."""
    arrays = [_as_signal(values, name) for name, values in named.items()]
    lengths = {name: array.size for name, array in zip(named, arrays)}
    if len(set(lengths.values())) > 1:
        listed = ", ".join(f"{name} {size}" for name, size in lengths.items())
        msg = f"Signals must have the same number of samples, got {listed}."
        raise SignalError(msg)
    return arrays


def _as_time(time_s: npt.ArrayLike) -> FloatArray:
    """Return ``time_s`` (s) as a strictly increasing finite array."""
    time = _as_signal(time_s, "time_s")
    if np.any(np.diff(time) <= 0.0):
        msg = "time_s must be strictly increasing (s)."
        raise SignalError(msg)
    return time


def _check_positive(value: float, name: str) -> None:
    if not (math.isfinite(value) and value > 0.0):
        msg = f"{name} must be a positive finite number, got {value!r}."
        raise SignalError(msg)


def _sample_interval(time: FloatArray) -> float:
    """Median sample interval (s)."""
    return float(np.median(np.diff(time)))


# --------------------------------------------------------------------------- filters


def _zero_phase(
    values: npt.ArrayLike,
    sample_rate_hz: float,
    cutoff_hz: float | tuple[float, float],
    btype: str,
    order: int,
) -> FloatArray:
    """Butterworth ``btype`` filter applied forward and backward (second-order sections)."""
    _check_positive(sample_rate_hz, "sample_rate_hz")
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
    array = _as_signal(values, "signal", min_samples=3 * taps + 1)
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
    _check_positive(sample_rate_hz, "sample_rate_hz")
    _check_positive(fundamental_hz, "fundamental_hz")
    if count < 1 or half_width_bins < 0:
        msg = f"count must be >= 1 and half_width_bins >= 0, got {count}, {half_width_bins}."
        raise SignalError(msg)
    if count * fundamental_hz >= 0.5 * sample_rate_hz:
        msg = (
            f"Harmonic {count} of {fundamental_hz} Hz is at or above the Nyquist frequency "
            f"of {sample_rate_hz} Hz sampling."
        )
        raise SignalError(msg)
    array = _as_signal(signal, "signal")
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


# --------------------------------------------------------------------------- cycles


def harmonic_phasor(signal: npt.ArrayLike, time_s: npt.ArrayLike, frequency_hz: float) -> complex:
    """Complex amplitude ``X`` of the ``frequency_hz`` component: ``x(t) ~ Re(X e^{jwt})``.

    Least-squares fit of ``offset + drift t + a cos(wt) + b sin(wt)`` over the samples
    (pass whole cycles), ``X = a - j b``. It is what the seed's 4-6 Hz band-pass isolates,
    in the limit of a narrow band, without the filter's transients at the segment's ends.
    """
    values, time = _as_same_length({"signal": signal, "time_s": time_s})
    time = _as_time(time)
    _check_positive(frequency_hz, "frequency_hz")
    phase = 2.0 * np.pi * frequency_hz * time
    centred = time - time.mean()
    basis = np.column_stack([np.ones_like(time), centred, np.cos(phase), np.sin(phase)])
    coefficients, *_ = np.linalg.lstsq(basis, values, rcond=None)
    return complex(coefficients[2], -coefficients[3])


def whole_cycles(
    start_s: float, end_s: float, period_s: float = EXCITATION_PERIOD_S
) -> tuple[float, float]:
    """Trim ``[start_s, end_s)`` (s) at its end to a whole number of periods ``period_s`` (s).

    Raises:
        SignalError: The interval is shorter than one period.
    """
    _check_positive(period_s, "period_s")
    cycles = math.floor((end_s - start_s) / period_s + 1e-9)
    if cycles < 1:
        msg = f"Interval {start_s:.6g}-{end_s:.6g} s is shorter than one period of {period_s} s."
        raise SignalError(msg)
    return start_s, start_s + cycles * period_s


def segment_slice(time_s: npt.ArrayLike, start_s: float, end_s: float) -> slice:
    """Index slice of the samples with ``start_s <= t < end_s`` (s).

    Bounds are compared half a sample interval early, so that a segment of ``m`` periods
    starting on a sample holds exactly ``m`` periods' worth of samples despite rounding.
    """
    time = _as_time(time_s)
    half = 0.5 * _sample_interval(time)
    first = int(np.searchsorted(time, start_s - half, side="left"))
    stop = int(np.searchsorted(time, end_s - half, side="left"))
    return slice(first, max(first, stop))


def _cycle_bounds(time: FloatArray, period_s: float) -> IndexArray:
    """Sample indices bounding the whole cycles ``[t0 + c T, t0 + (c + 1) T)``."""
    _check_positive(period_s, "period_s")
    interval = _sample_interval(time)
    span = time[-1] - time[0] + interval  # the last sample covers one interval
    cycles = math.floor((span + 0.5 * interval) / period_s)
    if cycles < 1:
        msg = (
            f"Signal spans {span:.6g} s, shorter than one period of {period_s} s: no whole "
            "cycle to analyse."
        )
        raise SignalError(msg)
    edges = time[0] + period_s * np.arange(cycles + 1) - 0.5 * interval
    bounds: IndexArray = np.searchsorted(time, edges, side="left")
    return bounds


def peak_to_peak(signal: npt.ArrayLike) -> float:
    """Peak-to-peak value ``max - min`` of ``signal`` (its unit)."""
    array = _as_signal(signal, "signal", min_samples=1)
    return float(array.max() - array.min())


def per_cycle_peak_to_peak(
    signal: npt.ArrayLike, time_s: npt.ArrayLike, period_s: float = EXCITATION_PERIOD_S
) -> float:
    """Median over whole cycles of the peak-to-peak value within each cycle (signal's unit).

    Cycles are ``[t0 + c T, t0 + (c + 1) T)`` from the first sample ``t0`` with ``T`` =
    ``period_s`` (s); a trailing partial cycle is ignored. The median makes the value
    insensitive to one disturbed cycle and, unlike :func:`peak_to_peak`, to a slow drift of
    the mean.

    Raises:
        SignalError: Mismatched lengths, NaN samples, or less than one whole cycle.
    """
    array, time = _as_same_length({"signal": signal, "time_s": time_s})
    time = _as_time(time)
    bounds = _cycle_bounds(time, period_s)
    starts = bounds[:-1]
    highs = np.maximum.reduceat(array, starts)[: starts.size]
    lows = np.minimum.reduceat(array, starts)[: starts.size]
    # reduceat's last group runs to the end of the array: recompute it within its cycle.
    last = slice(int(bounds[-2]), int(bounds[-1]))
    highs[-1] = array[last].max()
    lows[-1] = array[last].min()
    return float(np.median(highs - lows))


# --------------------------------------------------------------------------- time offsets


class CrossingOffsets(NamedTuple):
    """Time offsets (s) between predicted and measured mean crossings (seed Tables 4-5).

    Each is ``t_measured - t_predicted``: positive when the prediction crosses first.
    """

    tau_1_s: float
    """Falling edge (s)."""
    tau_2_s: float
    """Rising edge (s)."""
    tau_s: float
    """``(tau_1 + tau_2) / 2`` (s)."""


def _mean_crossings(
    values: FloatArray, time: FloatArray, bounds: IndexArray
) -> tuple[FloatArray, FloatArray]:
    """Times (s) where ``values`` crosses its mean downward and upward.

    The mean is taken over the whole cycles (``bounds``). A Schmitt trigger (band of
    +/- ``_CROSSING_HYSTERESIS`` of the half range around the mean) finds the edges, so
    noise near the mean cannot add crossings. An edge runs from the last sample beyond the
    band on one side to the first sample beyond it on the other; its crossing time is the
    zero of the least-squares straight line through those samples. With two samples (a
    steep edge) this is linear interpolation between them; with more it averages noise
    instead of picking one of several noisy sign changes.
    """
    centred = values - values[bounds[0] : bounds[-1]].mean()
    low, high = np.percentile(centred, [1.0, 99.0])
    band = _CROSSING_HYSTERESIS * 0.5 * float(high - low)
    state = np.where(centred > band, 1, np.where(centred < -band, -1, 0))
    marked = np.flatnonzero(state)
    levels = state[marked]
    switches = np.flatnonzero(np.diff(levels))
    falling: list[float] = []
    rising: list[float] = []
    for switch in switches:
        first, last = int(marked[switch]), int(marked[switch + 1])
        local_time = time[first : last + 1] - time[first]
        local_value = centred[first : last + 1]
        time_dev = local_time - local_time.mean()
        slope = float(np.dot(time_dev, local_value) / np.dot(time_dev, time_dev))
        if slope == 0.0:  # a pathological noisy edge: take its middle
            zero = float(local_time.mean())
        else:  # within the edge's samples
            zero = min(
                max(float(local_time.mean()) - float(local_value.mean()) / slope, 0.0),
                float(local_time[-1]),
            )
        (rising if levels[switch + 1] > 0 else falling).append(float(time[first] + zero))
    return np.asarray(falling, dtype=np.float64), np.asarray(rising, dtype=np.float64)


def _paired_offset(
    predicted: FloatArray, measured: FloatArray, period_s: float, edge: str
) -> float:
    """Mean of ``t_measured - t_predicted`` (s) over crossings paired within half a period."""
    for name, crossings in (("predicted", predicted), ("measured", measured)):
        if crossings.size == 0:
            msg = f"No {edge} mean crossing in the {name} signal."
            raise SignalError(msg)
    right = np.clip(np.searchsorted(predicted, measured), 1, predicted.size - 1)
    if predicted.size == 1:
        nearest = np.zeros(measured.size, dtype=np.intp)
    else:
        left = right - 1
        closer_left = np.abs(measured - predicted[left]) <= np.abs(predicted[right] - measured)
        nearest = np.where(closer_left, left, right)
    offsets = measured - predicted[nearest]
    offsets = offsets[np.abs(offsets) <= 0.5 * period_s]
    if offsets.size == 0:
        msg = f"No {edge} mean crossings of the two signals lie within half a period."
        raise SignalError(msg)
    return float(offsets.mean())


def mean_crossing_offsets(
    predicted: npt.ArrayLike,
    measured: npt.ArrayLike,
    time_s: npt.ArrayLike,
    period_s: float = EXCITATION_PERIOD_S,
) -> CrossingOffsets:
    """Time offsets (s) at the mean crossings, falling and rising (seed Tables 4-5).

    Each signal's crossings of its own mean (taken over the whole cycles of the window) are
    located between samples, one per edge: a hysteresis band of +/- 10 % of the half range
    keeps noise from adding crossings, and the crossing is the zero of a straight line
    fitted through the edge's samples inside the band (plain linear interpolation when the
    edge crosses the band between two samples). Each measured crossing is paired with the nearest
    predicted crossing of the same direction; pairs more than ``period_s / 2`` apart (at the
    window edges) are dropped. ``tau_1`` is the mean offset over falling edges, ``tau_2``
    over rising edges, ``tau = (tau_1 + tau_2) / 2``; each offset is
    ``t_measured - t_predicted``, positive when the prediction crosses first, as in the
    seed ("tau > 0 indicates that the predicted signal passes the mean value before the
    measured signal").

    Each signal crosses its own mean, so a DC offset or gain error in the prediction does
    not appear as a time offset. (The seed says the offset "is quantified at the mean value
    of the measured signal"; for a prediction with a different mean that level can miss the
    prediction entirely.)

    Args:
        predicted: Samples on the common time base ``time_s`` (same unit as ``measured``).
        measured: Samples on the common time base ``time_s`` (same unit as ``predicted``).
        time_s: Sample times (s), strictly increasing.
        period_s: Excitation period ``T`` (s); 0.2 s in the seed.

    Raises:
        SignalError: Mismatched lengths, NaN samples, less than one whole cycle, or no crossing of
            one direction that pairs.
    """
    predicted_arr, measured_arr, time = _as_same_length(
        {"predicted": predicted, "measured": measured, "time_s": time_s}
    )
    time = _as_time(time)
    bounds = _cycle_bounds(time, period_s)
    predicted_down, predicted_up = _mean_crossings(predicted_arr, time, bounds)
    measured_down, measured_up = _mean_crossings(measured_arr, time, bounds)
    tau_1 = _paired_offset(predicted_down, measured_down, period_s, "falling")
    tau_2 = _paired_offset(predicted_up, measured_up, period_s, "rising")
    return CrossingOffsets(tau_1, tau_2, 0.5 * (tau_1 + tau_2))


# --------------------------------------------------------------------------- errors


def nrmse(predicted: npt.ArrayLike, measured: npt.ArrayLike) -> float:
    """Normalised RMS error: ``RMS(predicted - measured) / (max(measured) - min(measured))``.

    Dimensionless (0 for a perfect prediction). Normalising by the measured peak-to-peak
    rather than the RMS of the measurement keeps the value meaningful for signals with a
    large mean (a bore pressure of 0.9 MPa mean pulsing by 0.6 MPa).

    Raises:
        SignalError: Mismatched lengths, NaN samples, or a measured signal with no range.
    """
    predicted_arr, measured_arr = _as_same_length({"predicted": predicted, "measured": measured})
    span = float(measured_arr.max() - measured_arr.min())
    if not span > 0.0:
        msg = "measured signal is constant: its peak-to-peak is zero, NRMSE is undefined."
        raise SignalError(msg)
    return float(np.sqrt(np.mean((predicted_arr - measured_arr) ** 2)) / span)


@dataclass(frozen=True)
class ChannelMetrics:
    """The seed's Tables 4-5 comparison of one channel over steady cycles."""

    ptp_ratio_pct: float
    """Predicted-to-measured per-cycle peak-to-peak ratio (%); 100 is perfect."""
    tau_over_T_pct: float
    """``100 tau / T`` (%), positive when the prediction crosses its mean first."""
    tau_1_s: float
    """Falling-edge time offset (s)."""
    tau_2_s: float
    """Rising-edge time offset (s)."""
    tau_s: float
    """``(tau_1 + tau_2) / 2`` (s)."""
    nrmse: float
    """RMS error over the measured peak-to-peak (-)."""
    predicted_ptp: float
    """Median per-cycle peak-to-peak of the prediction (channel unit)."""
    measured_ptp: float
    """Median per-cycle peak-to-peak of the measurement (channel unit)."""
    period_s: float
    """Excitation period ``T`` (s)."""
    cycles: int
    """Whole cycles analysed."""

    def as_dict(self) -> dict[str, float | int]:
        """Plain mapping for JSON (the ``M`` of ``compare`` and ``diagnosis.json``)."""
        return asdict(self)


def cycle_metrics(
    predicted: npt.ArrayLike,
    measured: npt.ArrayLike,
    time_s: npt.ArrayLike,
    period_s: float = EXCITATION_PERIOD_S,
) -> ChannelMetrics:
    """Compare a prediction with a measurement over steady cycles (seed Tables 4-5).

    Pass the samples of one steady segment (see :func:`steady_segments`), both filtered as
    the seed filters them. The peak-to-peak values are per-cycle medians
    (:func:`per_cycle_peak_to_peak`); the time offsets come from
    :func:`mean_crossing_offsets`; NRMSE from :func:`nrmse`.

    Args:
        predicted: Samples on the common time base ``time_s`` (same unit as ``measured``).
        measured: Samples on the common time base ``time_s`` (same unit as ``predicted``).
        time_s: Sample times (s), strictly increasing.
        period_s: Excitation period ``T`` (s); 0.2 s in the seed.

    Raises:
        SignalError: Mismatched lengths, NaN samples, less than one whole cycle, a measurement
            without oscillation, or no pairable mean crossings.
    """
    predicted_arr, measured_arr, time = _as_same_length(
        {"predicted": predicted, "measured": measured, "time_s": time_s}
    )
    time = _as_time(time)
    measured_ptp = per_cycle_peak_to_peak(measured_arr, time, period_s)
    if not measured_ptp > 0.0:
        msg = "measured signal does not oscillate: its peak-to-peak is zero."
        raise SignalError(msg)
    predicted_ptp = per_cycle_peak_to_peak(predicted_arr, time, period_s)
    offsets = mean_crossing_offsets(predicted_arr, measured_arr, time, period_s)
    return ChannelMetrics(
        ptp_ratio_pct=100.0 * predicted_ptp / measured_ptp,
        tau_over_T_pct=100.0 * offsets.tau_s / period_s,
        tau_1_s=offsets.tau_1_s,
        tau_2_s=offsets.tau_2_s,
        tau_s=offsets.tau_s,
        nrmse=nrmse(predicted_arr, measured_arr),
        predicted_ptp=predicted_ptp,
        measured_ptp=measured_ptp,
        period_s=period_s,
        cycles=int(_cycle_bounds(time, period_s).size - 1),
    )


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
    values, time = _as_same_length({"pressure": pressure, "time_s": time_s})
    time = _as_time(time)
    _check_positive(period_s, "period_s")
    _check_positive(sample_rate_hz, "sample_rate_hz")
    if settle_s < 0.0 or min_duration_s < 0.0:
        msg = f"settle_s and min_duration_s must be >= 0, got {settle_s}, {min_duration_s}."
        raise SignalError(msg)
    window = round(period_s * sample_rate_hz)
    if window < 4:
        msg = f"A period of {period_s} s at {sample_rate_hz} Hz holds fewer than 4 samples."
        raise SignalError(msg)
    if values.size < _MIN_SEGMENT_PERIODS * window:
        msg = (
            f"Recording of {values.size} samples is shorter than {_MIN_SEGMENT_PERIODS} "
            f"periods of {period_s} s: no steady segment can be found."
        )
        raise NoSteadyPulsingError(msg)

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
    steady = candidate & (amplitude >= _MIN_RELATIVE_AMPLITUDE * np.nanmax(amplitude[candidate]))

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
