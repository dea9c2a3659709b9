"""The paper's Tables 4-5 comparison metrics of a prediction against a measurement.

Over the steady cycles of one segment: the predicted-to-measured peak-to-peak ratio, the time
offset ``tau`` where the signals cross their mean, ``tau_1`` on the falling edge, ``tau_2``
on the rising edge, ``tau = (tau_1 + tau_2) / 2``, positive when the prediction crosses
first (:func:`mean_crossing_offsets`), given as ``tau / T``; and the NRMSE (:func:`nrmse`).
:func:`cycle_metrics` gives them all (:class:`ChannelMetrics`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from brake_hil.analysis.cycles import (
    EXCITATION_PERIOD_S,
    as_same_length,
    as_time,
    cycle_bounds,
    per_cycle_peak_to_peak,
)
from brake_hil.errors import SignalError
from brake_hil.types import FloatArray, IndexArray

__all__ = [
    "ChannelMetrics",
    "CrossingOffsets",
    "cycle_metrics",
    "mean_crossing_offsets",
    "nrmse",
]

# Schmitt-trigger band around the mean used to count one crossing per edge, as a fraction of
# the signal's half range (1st to 99th percentile): noise cannot add crossings.
_CROSSING_HYSTERESIS = 0.1


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
    predicted_arr, measured_arr, time = as_same_length(
        {"predicted": predicted, "measured": measured, "time_s": time_s}
    )
    time = as_time(time)
    bounds = cycle_bounds(time, period_s)
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
    predicted_arr, measured_arr = as_same_length({"predicted": predicted, "measured": measured})
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
    predicted_arr, measured_arr, time = as_same_length(
        {"predicted": predicted, "measured": measured, "time_s": time_s}
    )
    time = as_time(time)
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
        cycles=int(cycle_bounds(time, period_s).size - 1),
    )
