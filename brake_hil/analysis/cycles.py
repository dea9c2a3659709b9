"""Sampled signals and their whole cycles (numpy only).

The checks every function of :mod:`brake_hil.analysis.signals` applies to its input (a
finite 1-D array, one length, strictly increasing times), the excitation period ``T``, and
the cycles ``[t0 + c T, t0 + (c + 1) T)`` of a sampled signal: trimming to whole cycles,
cutting a segment out, the per-cycle peak-to-peak.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from brake_hil.errors import SignalError
from brake_hil.types import FloatArray, IndexArray

__all__ = [
    "EXCITATION_PERIOD_S",
    "as_same_length",
    "as_signal",
    "as_time",
    "check_positive",
    "cycle_bounds",
    "peak_to_peak",
    "per_cycle_peak_to_peak",
    "sample_interval",
    "segment_slice",
    "whole_cycles",
]

EXCITATION_PERIOD_S = 0.2
"""Period ``T`` of the paper's 5 Hz excitation (s)."""


# --------------------------------------------------------------------------- validation


def as_signal(values: npt.ArrayLike, name: str, min_samples: int = 2) -> FloatArray:
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


def as_same_length(named: dict[str, npt.ArrayLike]) -> list[FloatArray]:
    """Convert several signals and check that they have one length."""
    arrays = [as_signal(values, name) for name, values in named.items()]
    lengths = {name: array.size for name, array in zip(named, arrays)}
    if len(set(lengths.values())) > 1:
        listed = ", ".join(f"{name} {size}" for name, size in lengths.items())
        msg = f"Signals must have the same number of samples, got {listed}."
        raise SignalError(msg)
    return arrays


def as_time(time_s: npt.ArrayLike) -> FloatArray:
    """Return ``time_s`` (s) as a strictly increasing finite array."""
    time = as_signal(time_s, "time_s")
    if np.any(np.diff(time) <= 0.0):
        msg = "time_s must be strictly increasing (s)."
        raise SignalError(msg)
    return time


def check_positive(value: float, name: str) -> None:
    """Refuse a ``value`` that is not a positive finite number."""
    if not (math.isfinite(value) and value > 0.0):
        msg = f"{name} must be a positive finite number, got {value!r}."
        raise SignalError(msg)


def sample_interval(time: FloatArray) -> float:
    """Median sample interval (s)."""
    return float(np.median(np.diff(time)))


# --------------------------------------------------------------------------- cycles


def whole_cycles(
    start_s: float, end_s: float, period_s: float = EXCITATION_PERIOD_S
) -> tuple[float, float]:
    """Trim ``[start_s, end_s)`` (s) at its end to a whole number of periods ``period_s`` (s).

    Raises:
        SignalError: The interval is shorter than one period.
    """
    check_positive(period_s, "period_s")
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
    time = as_time(time_s)
    half = 0.5 * sample_interval(time)
    first = int(np.searchsorted(time, start_s - half, side="left"))
    stop = int(np.searchsorted(time, end_s - half, side="left"))
    return slice(first, max(first, stop))


def cycle_bounds(time: FloatArray, period_s: float) -> IndexArray:
    """Sample indices bounding the whole cycles ``[t0 + c T, t0 + (c + 1) T)``."""
    check_positive(period_s, "period_s")
    interval = sample_interval(time)
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
    array = as_signal(signal, "signal", min_samples=1)
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
    array, time = as_same_length({"signal": signal, "time_s": time_s})
    time = as_time(time)
    bounds = cycle_bounds(time, period_s)
    starts = bounds[:-1]
    highs = np.maximum.reduceat(array, starts)[: starts.size]
    lows = np.minimum.reduceat(array, starts)[: starts.size]
    # reduceat's last group runs to the end of the array: recompute it within its cycle.
    last = slice(int(bounds[-2]), int(bounds[-1]))
    highs[-1] = array[last].max()
    lows[-1] = array[last].min()
    return float(np.median(highs - lows))
