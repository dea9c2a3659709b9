"""``brake-hil regress`` per segment: each segment's metrics against the baseline's.

A replay is scored on every segment it holds (pulsing, sweeps, ramps, holds, steps,
modulated trains: :func:`~brake_hil.analysis.segment_comparison.score_prediction`), and
the baseline stores them (``segment_metrics``: one entry per segment, its ``kind``,
``t_start``, ``t_end`` and ``metrics`` per channel). :func:`segment_checks` matches each
segment of the replay with the baseline's of the same kind that overlaps it most (at least
half of the shorter) and checks the metric that fits its kind (:data:`SEGMENT_METRICS`)
against :data:`SEGMENT_TOLERANCES` (absolute; a baseline's ``tolerances`` may set any of
them). A segment only one side holds fails: ``NEW`` in the replay, ``LOST`` from the
baseline. A baseline entry without ``segment_metrics`` (one written before they were kept)
is checked on its top-level metrics alone.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
import math
from typing import Any, Final

from brake_hil.analysis.segment_metrics import HEADLINE_METRICS
from brake_hil.topics import OUTPUT_CHANNELS

__all__ = ["SEGMENT_METRICS", "SEGMENT_TOLERANCES", "segment_checks", "segment_name"]

SEGMENT_METRICS: Final = HEADLINE_METRICS
"""The metrics checked per segment kind: those that hold model against measurement (idle
has none). A metric a segment lacks (a ramp's loop width without a rise before it) is not
checked."""
SEGMENT_TOLERANCES: Final[dict[str, float]] = {
    "ptp_ratio_pct": 0.5,
    "tau_over_T_pct": 0.25,
    "nrmse": 0.005,
    "mean_gain_ratio_pct": 0.5,
    "mean_phase_error_deg": 0.5,
    "worst_error_pct": 0.5,
    "map_gain_ratio_pct": 0.5,
    "stick_error_pct": 0.5,
    "loop_width_error_pct": 0.5,
    "rise_time_ratio_pct": 2.0,
    "overshoot_error_pct": 0.5,
    "settling_error_s": 0.01,
    "level_error_pct": 0.5,
}
"""How far (absolute) a segment's metric may move from its baseline (units of the metric)."""
MIN_OVERLAP: Final = 0.5
"""Two segments match when they overlap by at least this share of the shorter."""

Row = tuple[str, str, str, float | None, float, float, str]
"""``(segment, channel, metric, baseline, value, tolerance, note)`` of one check."""


def segment_name(segment: Mapping[str, Any]) -> str:
    """``sweep 11.0-21.0 s``: a segment's kind and times, as the checks name it."""
    return f"{segment['kind']} {float(segment['t_start']):.1f}-{float(segment['t_end']):.1f} s"


def _overlap(a: Mapping[str, Any], b: Mapping[str, Any]) -> float:
    """Overlap of two segments over the shorter's length (0-1)."""
    start = max(float(a["t_start"]), float(b["t_start"]))
    end = min(float(a["t_end"]), float(b["t_end"]))
    shorter = min(float(a["t_end"]) - float(a["t_start"]), float(b["t_end"]) - float(b["t_start"]))
    return max(end - start, 0.0) / shorter if shorter > 0 else 0.0


def _checked(segment: Mapping[str, Any]) -> bool:
    """A segment with metrics of a kind that has some."""
    return bool(segment.get("metrics")) and bool(SEGMENT_METRICS.get(str(segment["kind"])))


def _match(
    segment: Mapping[str, Any], stored: Sequence[Mapping[str, Any]], used: set[int]
) -> int | None:
    """Index of the baseline's segment of the same kind that overlaps ``segment`` most."""
    best, best_overlap = None, MIN_OVERLAP
    for k, other in enumerate(stored):
        if k in used or other.get("kind") != segment["kind"]:
            continue
        overlap = _overlap(segment, other)
        if overlap >= best_overlap:
            best, best_overlap = k, overlap
    return best


def _number(value: object) -> float | None:
    """A metric's value as a float (None: not a number)."""
    return float(value) if isinstance(value, int | float) else None


def segment_checks(
    scored: Sequence[Mapping[str, Any]],
    stored: Sequence[Mapping[str, Any]] | None,
    tolerances: Mapping[str, float],
) -> list[Row]:
    """Each checked metric of each segment of a replay against the baseline's segments.

    Args:
        scored: the replay's segments (``ReplayResult.scored_segments``).
        stored: the baseline's ``segment_metrics`` of the bag; ``None``: the baseline keeps
            none for it (no check).
        tolerances: a baseline's tolerances (:data:`SEGMENT_TOLERANCES` fill the rest).

    Returns:
        One row per check; a segment only the replay holds gives rows without a baseline
        (``NEW``), one only the baseline holds a ``LOST`` row.
    """
    if stored is None:
        return []
    limits = {**SEGMENT_TOLERANCES, **tolerances}
    kept = [s for s in stored if isinstance(s, Mapping) and _checked(s)]
    used: set[int] = set()
    rows: list[Row] = []
    for segment in (s for s in scored if _checked(s)):
        k = _match(segment, kept, used)
        reference = {} if k is None else kept[k]["metrics"]
        if k is not None:
            used.add(k)
        for channel in OUTPUT_CHANNELS:
            values = segment["metrics"].get(channel, {})
            for metric in SEGMENT_METRICS[str(segment["kind"])]:
                value = _number(values.get(metric))
                if value is None:
                    continue
                base = _number(reference.get(channel, {}).get(metric)) if reference else None
                tolerance = float(limits.get(metric, math.inf))
                rows.append((segment_name(segment), channel, metric, base, value, tolerance, ""))
    for k, segment in enumerate(kept):
        if k not in used:
            rows.append((segment_name(segment), "-", "segment", 1.0, math.nan, 0.0, "LOST"))
    return rows
