"""A live run kept whole and scored per segment at its end, as ``compare`` scores a recording.

The comparator scores steady pulsing cycle by cycle as they come; a ramp, a sweep or a test
procedure has none. :class:`RunLog` keeps what the comparator received (the measured
``p_i`` and each channel's prediction and measurement, by stamp, up to :data:`MAX_RUN_S`),
and :func:`score_run` splits it into its segments
(:func:`~brake_hil.analysis.segmentation.find_segments`) and scores each with the metric
that fits its kind (:func:`~brake_hil.analysis.segment_comparison.score_prediction`, the
code ``regress`` uses). Samples are aligned on their stamps; a stamp some series lack is
interpolated from its neighbours (lost samples), and the share of such stamps is reported.
"""

from __future__ import annotations

from array import array
from pathlib import Path
from typing import Any, Final

import numpy as np

from brake_hil.analysis.recording import Recording
from brake_hil.analysis.segment_comparison import score_prediction
from brake_hil.analysis.segment_metrics import HEADLINE_METRICS
from brake_hil.errors import BrakeHilError
from brake_hil.topics import OUTPUT_CHANNELS

__all__ = ["MAX_RUN_S", "RunLog", "score_run", "segment_lines"]

MAX_RUN_S: Final = 1800.0
"""The longest run kept for scoring per segment (s of stamps at 1 kHz: 7 series of 16 bytes a
sample, about 200 MB); later samples are counted, not kept."""
MIN_RUN_S: Final = 1.0
"""A run shorter than this (s, stamps every series holds) is not scored per segment."""
SERIES: Final = ("p_i", *(f"{c}_{side}" for c in OUTPUT_CHANNELS for side in ("pred", "meas")))
"""The series a run keeps: measured ``p_i``, then each channel's prediction and measurement."""


class RunLog:
    """Every sample of a run by stamp (ns), per series of :data:`SERIES`; not thread-safe."""

    def __init__(self, sample_period_s: float, max_s: float = MAX_RUN_S) -> None:
        """Keep up to ``max_s`` of samples at ``sample_period_s`` (s) per series."""
        self.sample_period_s = sample_period_s
        self._limit = int(max_s / sample_period_s)
        self._stamps = {name: array("q") for name in SERIES}
        self._values = {name: array("d") for name in SERIES}
        self.dropped = 0  # samples past the limit

    def extend(self, name: str, stamps: list[int], values: list[float]) -> None:
        """Samples of one series (``stamps`` in ns, ``values`` in the channel's unit)."""
        room = self._limit - len(self._stamps[name])
        if room < len(stamps):
            self.dropped += len(stamps) - max(room, 0)
            stamps, values = stamps[: max(room, 0)], values[: max(room, 0)]
        self._stamps[name].extend(stamps)
        self._values[name].extend(values)

    def samples(self, name: str) -> int:
        """Samples kept of one series."""
        return len(self._stamps[name])

    def aligned(self) -> tuple[np.ndarray, dict[str, np.ndarray], float]:
        """A uniform stamp grid (ns) over what every series covers, each series on it.

        Returns the grid, the series on it, and the share of grid stamps some series lacked
        (interpolated).

        Raises:
            BrakeHilError: a series is empty, or the series share less than :data:`MIN_RUN_S`.
        """
        series: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        for name in SERIES:
            stamps = np.frombuffer(self._stamps[name], dtype=np.int64)
            if stamps.size == 0:
                raise BrakeHilError(f"no {name.replace('_', ' ')} sample received")
            order = np.argsort(stamps, kind="stable")
            stamps, first = np.unique(stamps[order], return_index=True)
            series[name] = (stamps, np.frombuffer(self._values[name])[order][first])
        start = max(int(s[0]) for s, _ in series.values())
        end = min(int(s[-1]) for s, _ in series.values())
        period_ns = round(self.sample_period_s * 1e9)
        if end - start < MIN_RUN_S * 1e9:
            raise BrakeHilError(
                f"the series share {max(end - start, 0) / 1e9:.2f} s of stamps, under "
                f"{MIN_RUN_S:g} s"
            )
        grid = np.arange(start, end + 1, period_ns, dtype=np.int64)
        missing = np.zeros(grid.size, dtype=bool)
        on_grid = {}
        for name, (stamps, values) in series.items():
            missing |= ~np.isin(grid, stamps)
            on_grid[name] = np.interp(grid.astype(float), stamps.astype(float), values)
        return grid, on_grid, float(np.mean(missing))


def score_run(log: RunLog, excitation_hz: float) -> dict[str, Any]:
    """Every segment of the run scored; the JSON the comparator's summary holds.

    ``{"segments": [...], "basis": ..., "metrics": {channel: {...}}, "interpolated_share":
    ..., "dropped_samples": ...}``, each segment as ``compare --json`` gives it (without a
    sweep's per-band points); with nothing scored, ``{"segments": [...], "unscored": why}``.
    """
    try:
        grid, series, interpolated = log.aligned()
    except BrakeHilError as err:
        return {"segments": [], "unscored": str(err), "dropped_samples": log.dropped}
    time = (grid - grid[0]).astype(float) / 1e9
    recording = Recording(
        path=Path("the live run"),
        time=time,
        master_cylinder_pressure=series["p_i"],
        bore_pressure=series["p_b_meas"],
        block_force=series["F_k_meas"],
        caliper_displacement=series["x_c_meas"],
    )
    predicted = {c: series[f"{c}_pred"] for c in OUTPUT_CHANNELS}
    mean = float(np.mean(series["p_i"]))
    document: dict[str, Any] = {
        "interpolated_share": interpolated,
        "dropped_samples": log.dropped,
        "start_stamp_ns": int(grid[0]),
    }
    try:
        comparison = score_prediction(recording, predicted, excitation_hz, mean)
    except BrakeHilError as err:
        return {"segments": [], "unscored": str(err), **document}
    segments = [s.as_dict(response=False) for s in comparison.segments]
    return {
        "segments": segments,
        "basis": "non_idle_segments",
        "metrics": comparison.metrics(),
        **document,
    }


def segment_lines(document: dict[str, Any]) -> list[str]:
    """One line per segment and channel of :func:`score_run`'s JSON, idle left out.

    Its kind, times (s from the run's first shared stamp) and headline metrics.
    """
    if not document.get("segments"):
        return [f"no segment scored: {document.get('unscored', 'nothing received')}"]
    lines = []
    for segment in document["segments"]:
        where = f"{segment['kind']} {segment['t_start']:.1f}-{segment['t_end']:.1f} s"
        if segment["kind"] == "idle":
            continue
        if segment.get("unscored"):
            lines.append(f"{where}: not scored ({segment['unscored']})")
            continue
        for channel, metrics in segment["metrics"].items():
            keys = HEADLINE_METRICS.get(segment["kind"], ())
            text = ", ".join(f"{k} {metrics[k]:.4g}" for k in keys if k in metrics)
            lines.append(f"{where} {channel}: {text}")
    return lines
