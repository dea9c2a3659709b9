"""A nightly regression over time: each recording's metrics across its stored runs, in words.

A database that holds only ``regress`` or ``compare`` runs has no diagnosis to trend; what
it has is the paper's Table 4-5 metrics (peak-to-peak ratio, tau/T, NRMSE) of each recording
per run. Per recording (and kind, and rig name) the runs in the order they ran become a
series per channel and metric, held against a reference and a tolerance: the regression
baseline's value and tolerance when one is given (``trend --baseline``), else the first
stored run's value and ``regress``'s default tolerances
(:data:`~brake_hil.analysis.stamp_scoring.DEFAULT_TOLERANCES`). A run past the tolerance is
said in one line; a recording whose runs all stay within it says so.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass

from brake_hil.analysis.stamp_scoring import DEFAULT_TOLERANCES, METRIC_KEYS
from brake_hil.results.rows import MetricsRun
from brake_hil.words import counted

__all__ = ["Reference", "RecordingTrend", "metrics_trends"]

Reference = Callable[[str], Mapping[str, Mapping[str, float]] | None]
"""A recording's path -> its baseline metrics (channel -> metric -> value), or ``None``."""


@dataclass(frozen=True)
class RecordingTrend:
    """One recording's metrics across its runs (one kind, one rig name)."""

    recording: str  # its path as last stored
    kind: str  # regression or comparison
    rig: str
    runs: tuple[MetricsRun, ...]  # in the order they ran
    model: str  # the model whose metrics are drawn (regression/comparison: "model")
    reference: Mapping[str, Mapping[str, float]]  # channel -> metric -> reference value
    tolerances: Mapping[str, float]  # metric -> absolute tolerance
    from_baseline: bool  # the reference is the baseline's (else the first run's)

    @property
    def channels(self) -> tuple[str, ...]:
        """The channels of the latest run."""
        return tuple(self.runs[-1].metrics.get(self.model, {}))

    def series(self, channel: str, metric: str) -> list[float | None]:
        """One metric of one channel per run (``None``: that run did not give it)."""
        return [run.metrics.get(self.model, {}).get(channel, {}).get(metric) for run in self.runs]

    def beyond(self) -> list[tuple[str, str, int, float, float]]:
        """(channel, metric, run index, value, reference) of every value past its tolerance."""
        found = []
        for channel in self.channels:
            for metric in METRIC_KEYS:
                reference = self.reference.get(channel, {}).get(metric)
                if reference is None:
                    continue
                for index, value in enumerate(self.series(channel, metric)):
                    if value is not None and abs(value - reference) > self.tolerances[metric]:
                        found.append((channel, metric, index, value, reference))
        return found

    def summary(self) -> list[str]:
        """A line per channel and metric that left its tolerance, or that none did."""
        against = "the baseline" if self.from_baseline else "the first run"
        count = len(self.runs)
        lines = []
        latest: dict[tuple[str, str], tuple[int, float, float]] = {}
        for channel, metric, index, value, reference in self.beyond():
            latest[(channel, metric)] = (index, value, reference)
        for (channel, metric), (index, value, reference) in latest.items():
            runs = sum(1 for c, m, *_ in self.beyond() if (c, m) == (channel, metric))
            lines.append(
                f"{channel} {metric}: {value:.4g} in run {index + 1} of {count} against "
                f"{reference:.4g} in {against}, beyond its tolerance ±{self.tolerances[metric]:g}"
                f" ({runs} run{'s' if runs > 1 else ''} beyond it)"
            )
        if not lines:
            lines.append(
                f"every metric within its tolerance of {against} over {counted(count, 'run')}"
            )
        return lines


def metrics_trends(
    runs: Iterable[MetricsRun],
    baseline: Reference | None = None,
    tolerances: Mapping[str, float] | None = None,
) -> list[RecordingTrend]:
    """One :class:`RecordingTrend` per (recording, kind, rig name), sorted by recording path.

    Args:
        runs: the stored runs in the order they ran
            (:meth:`~brake_hil.results.store.ResultsStore.metrics_runs`).
        baseline: the baseline's metrics of a recording by its path (``None``: no baseline:
            each recording's first run is its reference).
        tolerances: absolute tolerance per metric (default: ``regress``'s).
    """
    limits = {**DEFAULT_TOLERANCES, **(tolerances or {})}
    groups: dict[tuple[str, str, str], list[MetricsRun]] = {}
    for run in runs:
        groups.setdefault((run.recording_hash, run.kind, run.rig_name), []).append(run)
    result = [_trend(group, baseline, limits) for group in groups.values()]
    return sorted(result, key=lambda t: (t.recording, t.kind, t.rig))


def _trend(
    runs: Sequence[MetricsRun], baseline: Reference | None, tolerances: Mapping[str, float]
) -> RecordingTrend:
    last = runs[-1]
    model = "model" if "model" in last.metrics else next(iter(last.metrics), "model")
    stored = baseline(last.recording_path) if baseline is not None else None
    reference = stored if stored is not None else runs[0].metrics.get(model, {})
    return RecordingTrend(
        recording=last.recording_path,
        kind=last.kind,
        rig=last.rig_name,
        runs=tuple(runs),
        model=model,
        reference=reference,
        tolerances=tolerances,
        from_baseline=stored is not None,
    )
