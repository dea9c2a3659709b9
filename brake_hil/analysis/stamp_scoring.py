"""The comparator's scoring, shared by the ``comparator`` node and ``brake-hil regress``.

Predictions paired with measurements by stamp, the seed's Table 4-5 metrics per cycle and
window, OK/WARN/ERROR thresholds.
"""

from __future__ import annotations

import bisect
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
import math
from typing import NamedTuple

import numpy as np

from brake_hil.analysis import signals
from brake_hil.errors import SignalError
from brake_hil.types import FloatArray, IntArray

METRIC_KEYS = ("ptp_ratio_pct", "tau_over_T_pct", "nrmse")
"""The seed's Table 4-5 metrics, the ones thresholds and tolerances apply to."""
OK, WARN, ERROR = 0, 1, 2
"""Levels, as ``diagnostic_msgs/msg/DiagnosticStatus``."""
DEFAULT_TOLERANCES: dict[str, float] = {
    "ptp_ratio_pct": 0.5,
    "tau_over_T_pct": 0.25,
    "nrmse": 0.005,
}
"""How far (absolute) a metric may move from its baseline before ``regress`` fails."""
HORIZON_NS = 30_000_000_000
"""How long (ns of stamps) a sample waits for its partner: as long as the recorder keeps."""
UNPAIRED_REASONS = ("behind", "mismatch")
"""Why a sample was dropped unpaired: its partner side was more than the horizon ``behind``;
or it had passed the stamp without an equal one (``mismatch``: an offset, another clock)."""


# --------------------------------------------------------------------------- thresholds


@dataclass(frozen=True)
class Thresholds:
    """Levels of a channel's metrics: WARN or ERROR past these (absolute) deviations."""

    ptp_ratio_warn_pct: float = 10.0  # |ptp ratio - 100 %|
    ptp_ratio_error_pct: float = 25.0
    tau_over_T_warn_pct: float = 2.5  # |tau / T|
    tau_over_T_error_pct: float = 5.0
    nrmse_warn: float = 0.15
    nrmse_error: float = 0.30

    def level(self, metrics: Mapping[str, float]) -> int:
        """OK, WARN or ERROR of one channel's ``{ptp_ratio_pct, tau_over_T_pct, nrmse}``."""
        ptp = abs(metrics["ptp_ratio_pct"] - 100.0)
        tau = abs(metrics["tau_over_T_pct"])
        deviations = (
            (ptp, self.ptp_ratio_warn_pct, self.ptp_ratio_error_pct),
            (tau, self.tau_over_T_warn_pct, self.tau_over_T_error_pct),
            (metrics["nrmse"], self.nrmse_warn, self.nrmse_error),
        )
        level = OK
        for value, warn, error in deviations:
            if not math.isfinite(value) or value > error:
                return ERROR
            if value > warn:
                level = WARN
        return level


# --------------------------------------------------------------------------- pairing


class PairedWindow(NamedTuple):
    """Paired samples of one channel, in stamp order."""

    stamps_ns: IntArray  # header.stamp (ns)
    predicted: FloatArray  # channel unit
    measured: FloatArray  # channel unit


@dataclass
class StampPairer:
    """Pairs predicted with measured samples of one channel by equal stamps.

    Samples wait for their partner in insertion-ordered dicts for ``horizon_ns`` of their own
    side's stamps (30 s, as long as the recorder keeps history): a side that falls behind is
    paired late, not dropped. A sample that waited longer is dropped and counted by reason
    (:attr:`unpaired_reasons`): ``mismatch`` when the other side had passed its stamp without
    an equal one (stamps that never match: an offset, another clock, a sample lost on the other
    side), ``behind`` when the other side had not reached it (no partner within the horizon).
    ``max_pending`` caps each side (a safety bound: stamps out of order), dropped as ``behind``.
    Memory: at most ``max_pending`` samples a side. The newest ``capacity`` pairs are kept in
    stamp order (30 s by default: a consumer that takes them late still finds its windows).
    Not thread-safe: feed it from one thread.
    """

    capacity: int = HORIZON_NS // 1_000_000
    horizon_ns: int = HORIZON_NS
    max_pending: int = 2 * HORIZON_NS // 1_000_000
    paired: int = 0
    unpaired_predicted: int = 0
    unpaired_measured: int = 0
    unpaired_reasons: dict[str, int] = field(
        default_factory=lambda: dict.fromkeys(UNPAIRED_REASONS, 0)
    )
    _predicted: dict[int, float] = field(default_factory=dict, repr=False)
    _measured: dict[int, float] = field(default_factory=dict, repr=False)
    _newest: list[int | None] = field(default_factory=lambda: [None, None], repr=False)
    _pairs: list[tuple[int, float, float]] = field(default_factory=list, repr=False)

    def add_predicted(self, stamp_ns: int, value: float) -> None:
        """One predicted sample."""
        partner = self._measured.pop(stamp_ns, None)
        if partner is None:
            self._wait(0, stamp_ns, value)
        else:
            self._pair(stamp_ns, value, partner)
            self._see(0, stamp_ns)

    def add_measured(self, stamp_ns: int, value: float) -> None:
        """One measured sample."""
        partner = self._predicted.pop(stamp_ns, None)
        if partner is None:
            self._wait(1, stamp_ns, value)
        else:
            self._pair(stamp_ns, partner, value)
            self._see(1, stamp_ns)

    def _pair(self, stamp_ns: int, predicted: float, measured: float) -> None:
        """Keep a pair in stamp order (pairs come mostly in order: an append), newest kept."""
        pairs = self._pairs
        entry = (stamp_ns, predicted, measured)
        if not pairs or stamp_ns >= pairs[-1][0]:
            pairs.append(entry)
        else:
            bisect.insort(pairs, entry)
        self.paired += 1
        if len(pairs) > self.capacity + 1000:  # trimmed in chunks: amortised O(1)
            del pairs[: len(pairs) - self.capacity]

    def _see(self, side: int, stamp_ns: int) -> None:
        newest = self._newest[side]
        if newest is None or stamp_ns > newest:
            self._newest[side] = stamp_ns

    def _wait(self, side: int, stamp_ns: int, value: float) -> None:
        """Hold a sample of ``side`` (0 predicted, 1 measured); drop what waited too long."""
        self._see(side, stamp_ns)
        pending = self._measured if side else self._predicted
        pending[stamp_ns] = value
        oldest_kept = stamp_ns - self.horizon_ns
        while pending:
            first = next(iter(pending))
            if first >= oldest_kept and len(pending) <= self.max_pending:
                break
            del pending[first]
            self._drop(side, first)

    def _drop(self, side: int, stamp_ns: int) -> None:
        if side:
            self.unpaired_measured += 1
        else:
            self.unpaired_predicted += 1
        self.unpaired_reasons[self._reason(side, stamp_ns)] += 1

    def _reason(self, side: int, stamp_ns: int) -> str:
        other = self._newest[1 - side]
        return "mismatch" if other is not None and other >= stamp_ns else "behind"

    @property
    def pending(self) -> tuple[int, int]:
        """Samples waiting for a partner: ``(predicted, measured)``."""
        return len(self._predicted), len(self._measured)

    def unpaired_now(self) -> dict[str, int]:
        """Unpaired samples by reason, counting those still waiting as if the run ended now.

        Waiting samples whose stamp the other side has passed are ``mismatch``; the others are
        ``end`` (the run ended before their partner came).
        """
        counts = dict(self.unpaired_reasons)
        counts["end"] = 0
        for side, pending in enumerate((self._predicted, self._measured)):
            for stamp in pending:
                reason = self._reason(side, stamp)
                counts["end" if reason == "behind" else reason] += 1
        return counts

    def window(self, since_ns: int | None = None) -> PairedWindow:
        """The paired samples held (those stamped ``since_ns`` or later), sorted by stamp."""
        pairs = self._pairs
        if since_ns is not None:
            pairs = pairs[bisect.bisect_left(pairs, (since_ns,)) :]
        stamps = np.fromiter((p[0] for p in pairs), dtype=np.int64, count=len(pairs))
        predicted = np.fromiter((p[1] for p in pairs), dtype=np.float64, count=len(pairs))
        measured = np.fromiter((p[2] for p in pairs), dtype=np.float64, count=len(pairs))
        return PairedWindow(stamps, predicted, measured)


# --------------------------------------------------------------------------- scoring


def metrics_dict(metrics: signals.ChannelMetrics) -> dict[str, float]:
    """The metrics of one channel as floats (JSON-ready)."""
    return {key: float(value) for key, value in metrics.as_dict().items()}


def weighted_metrics(parts: Sequence[signals.ChannelMetrics]) -> dict[str, float]:
    """Cycle-weighted means of several segments' metrics (as ``compare`` reports them)."""
    weights = np.array([m.cycles for m in parts], dtype=float)
    keys = (*METRIC_KEYS, "tau_1_s", "tau_2_s", "predicted_ptp", "measured_ptp")
    result = {
        key: float(np.average([getattr(m, key) for m in parts], weights=weights)) for key in keys
    }
    result["cycles"] = float(weights.sum())
    return result


def resample(
    stamps_ns: IntArray, start_ns: int, count: int, period_ns: int, *values: FloatArray
) -> tuple[FloatArray, list[FloatArray]]:
    """Time of ``count`` samples ``period_ns`` apart, and ``values`` interpolated there.

    Time is in s from ``start_ns``; ``values`` (sampled at ``stamps_ns``) are linearly
    interpolated: exact where no pair is missing.
    """
    grid = np.arange(count, dtype=np.float64) * period_ns
    relative = (stamps_ns - start_ns).astype(np.float64)
    return grid / 1e9, [np.interp(grid, relative, series) for series in values]


class WindowResult(NamedTuple):
    """The comparator's figures for one channel and one cycle."""

    steady: bool  # the window is steady pulsing and scored
    cycle: dict[str, float] | None  # metrics of the cycle (None: see reason)
    window: dict[str, float] | None  # metrics over the rolling window ending with it
    reason: str  # why a figure is missing ("" when both are there)


def evaluate_cycle(
    window: PairedWindow,
    cycle_end_ns: int,
    period_s: float = signals.EXCITATION_PERIOD_S,
    window_cycles: int = 10,
    sample_period_ns: int = 1_000_000,
    min_steady_share: float = 0.8,
    min_paired_share: float = 0.95,
) -> WindowResult:
    """Metrics of the cycle ending at ``cycle_end_ns`` and of its rolling window, one channel.

    The window is the ``window_cycles`` cycles ending with that cycle, scored on one channel's
    paired samples.

    One guard period on each side of the window is low-passed with it (30 Hz, zero phase)
    but not scored, against the filter's edge effects; ``window`` must hold samples up to one
    period after ``cycle_end_ns``. The window counts when :func:`signals.steady_segments`
    finds steady pulsing over at least ``min_steady_share`` of it, and when at least
    ``min_paired_share`` of its samples are paired (missing ones are interpolated linearly).
    """
    stamps, predicted, measured = window
    period_ns = round(period_s * 1e9)
    start_ns = cycle_end_ns - (window_cycles + 1) * period_ns
    stop_ns = cycle_end_ns + period_ns
    if stamps.size < 2 or stamps[0] > start_ns or stamps[-1] < stop_ns - sample_period_ns:
        return WindowResult(False, None, None, "window not covered by paired samples")
    keep = (stamps >= start_ns - sample_period_ns) & (stamps <= stop_ns + sample_period_ns)
    count = (stop_ns - start_ns) // sample_period_ns
    present = int(np.count_nonzero(keep))
    if present < min_paired_share * count:
        return WindowResult(
            False, None, None, f"only {present} of {count} samples of the window are paired"
        )
    time_s, (pred, meas) = resample(
        stamps[keep], start_ns, count, sample_period_ns, predicted[keep], measured[keep]
    )
    rate = 1e9 / sample_period_ns
    first_s, end_s = period_s, (cycle_end_ns - start_ns) / 1e9
    try:
        segments = signals.steady_segments(
            time_s, meas, rate, period_s, settle_s=0.0, min_duration_s=0.0
        )
    except SignalError as err:
        return WindowResult(False, None, None, f"not steady: {err}")
    covered = sum(max(0.0, min(end_s, b) - max(first_s, a)) for a, b in segments)
    if covered < min_steady_share * (end_s - first_s):
        share = covered / (end_s - first_s)
        return WindowResult(False, None, None, f"steady pulsing over {share:.0%} of the window")
    filtered_pred = signals.lowpass(pred, rate)
    filtered_meas = signals.lowpass(meas, rate)
    scored = signals.segment_slice(time_s, first_s, end_s)
    last = signals.segment_slice(time_s, end_s - period_s, end_s)
    try:
        window_metrics = signals.cycle_metrics(
            filtered_pred[scored], filtered_meas[scored], time_s[scored], period_s
        )
    except SignalError as err:
        return WindowResult(False, None, None, f"no metrics: {err}")
    try:  # one cycle: a mean crossing right at its edge may be missed
        cycle: dict[str, float] | None = metrics_dict(
            signals.cycle_metrics(filtered_pred[last], filtered_meas[last], time_s[last], period_s)
        )
        reason = ""
    except SignalError as err:
        cycle, reason = None, f"no metrics for the cycle alone: {err}"
    return WindowResult(True, cycle, metrics_dict(window_metrics), reason)


def peak_stamp_ns(window: PairedWindow, period_s: float = signals.EXCITATION_PERIOD_S) -> int:
    """Stamp (ns) of a maximum of the measured signal's fundamental (``1 / period_s``).

    The maximum lies in ``window``; cycles that start there hold both mean crossings well
    inside them.
    """
    stamps, _, measured = window
    time_s = (stamps - stamps[0]).astype(np.float64) / 1e9
    phasor = signals.harmonic_phasor(measured, time_s, 1.0 / period_s)
    # x(t) ~ Re(X exp(j w t)) peaks where w t = -arg X (mod 2 pi)
    fraction = (-np.angle(phasor) / (2.0 * np.pi)) % 1.0
    return int(stamps[0]) + round(fraction * period_s * 1e9)


def score_segments(
    time_s: FloatArray,
    predicted: Mapping[str, FloatArray],
    measured: Mapping[str, FloatArray],
    segments: Sequence[tuple[float, float]],
    period_s: float = signals.EXCITATION_PERIOD_S,
) -> dict[str, dict[str, float]]:
    """Cycle-weighted metrics per channel over ``segments`` (s), both sides low-passed."""
    rate = float(1.0 / np.median(np.diff(time_s)))
    result = {}
    for channel in predicted:
        pred = signals.lowpass(predicted[channel], rate)
        meas = signals.lowpass(measured[channel], rate)
        parts = []
        for start, end in segments:
            part = signals.segment_slice(time_s, start, end)
            parts.append(signals.cycle_metrics(pred[part], meas[part], time_s[part], period_s))
        result[channel] = weighted_metrics(parts)
    return result


def expected_cycles(
    stamps_ns: IntArray,
    measured: Mapping[str, FloatArray],
    period_s: float = signals.EXCITATION_PERIOD_S,
    window_cycles: int = 10,
    sample_period_ns: int = 1_000_000,
) -> dict[str, int]:
    """Steady cycles the comparator scores per channel on a recording when nothing is lost.

    The comparator's grid and scoring (:func:`evaluate_cycle`) on the recording's measured
    samples paired with themselves: what a live run that kept up pairs. The first channel
    (``p_b``) places the grid at its peak once it is first steady, as the node does.
    """
    period_ns = round(period_s * 1e9)
    span_ns = (window_cycles + 2) * period_ns
    counts = dict.fromkeys(measured, 0)
    if stamps_ns.size < 2:
        return counts
    cycle_end = int(stamps_ns[0]) + (window_cycles + 1) * period_ns
    aligned = False
    first = next(iter(measured))
    while cycle_end + period_ns <= int(stamps_ns[-1]):
        low, high = np.searchsorted(stamps_ns, (cycle_end - span_ns, cycle_end + 2 * period_ns))
        stamps = stamps_ns[low:high]
        steady_first = False
        for channel, values in measured.items():
            part = values[low:high]
            try:
                result = evaluate_cycle(
                    PairedWindow(stamps, part, part),
                    cycle_end,
                    period_s,
                    window_cycles,
                    sample_period_ns,
                )
            except ValueError:
                continue
            counts[channel] += result.steady and result.cycle is not None
            steady_first = steady_first or (channel == first and result.steady)
        cycle_end += period_ns
        if steady_first and not aligned:
            keep = slice(max(0, high - span_ns // sample_period_ns), high)
            part = measured[first][keep]
            peak = peak_stamp_ns(PairedWindow(stamps_ns[keep], part, part), period_s)
            half = period_ns // 2
            cycle_end = peak - ((peak - (cycle_end - half)) // period_ns) * period_ns
            aligned = True
    return counts
