"""The comparator's metrics, and replay regression of recordings against a baseline (ROS-free).

Scoring (shared by the ``comparator`` node and ``brake-hil regress``, so both agree):
predicted and measured samples are paired by stamp (:class:`StampPairer`); both are
conditioned alike with the seed's 30 Hz zero-phase low-pass (:func:`signals.lowpass`) and
compared with the seed's Table 4-5 metrics (:func:`signals.cycle_metrics`: peak-to-peak ratio,
``tau/T``, NRMSE) over steady 5 Hz cycles only. The live model steps on raw ``p_i``; filtering
its output equals filtering its input (the model is linear), so the scores match
``brake-hil compare`` up to the filter's edge effects and the operating point (``compare``
derives the model at each segment's own mean pressure, the live model at one).

* :func:`evaluate_cycle`: the comparator's figures for one cycle and the rolling window that
  ends with it, with a guard cycle at each end of the window against filter edge effects,
  and only when the window is steady pulsing (:func:`signals.steady_segments`).
* :class:`Thresholds`: OK / WARN / ERROR of a channel's metrics.
* :func:`replay_recording`: a recording through the live model's per-sample stepper (the
  node's code path, faster than real time), scored over the recording's steady segments.
* :func:`compare_with_baseline`: metric by metric against a stored baseline, with absolute
  tolerances; :func:`load_baseline` / :func:`baseline_document` read and write its JSON;
  :func:`run_regression` is ``brake-hil regress`` (bags replayed in parallel in a process
  pool; the reader is passed in, so this module stays free of the I/O layer).

Baseline JSON: ``{"model_file": path relative to the baseline's folder, "tolerances":
{metric: absolute tolerance}, "bags": {name: {"metrics": {channel: {metric: value}}, ...}}}``,
a bag named by its path relative to the baseline's folder.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
import json
import math
import os
from pathlib import Path
import time
from typing import Any, NamedTuple

import numpy as np

from brake_hil.core import signals
from brake_hil.core.model_file import load_model
from brake_hil.core.realtime import IntArray
from brake_hil.core.recording import Recording
from brake_hil.core.types import FloatArray
from brake_hil.errors import BrakeHilError, RecordingError, SignalError
from brake_hil.topics import OUTPUT_CHANNELS

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


class BaselineError(BrakeHilError, ValueError):
    """A baseline file is missing, unreadable or malformed."""


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

    Samples wait for their partner in insertion-ordered dicts; when more than ``max_pending``
    wait on one side the oldest are dropped and counted as unpaired. Paired samples are kept
    in a ring of ``capacity``. Not thread-safe: feed it from one thread.
    """

    capacity: int = 4000
    max_pending: int = 2000
    paired: int = 0
    unpaired_predicted: int = 0
    unpaired_measured: int = 0
    _predicted: dict[int, float] = field(default_factory=dict, repr=False)
    _measured: dict[int, float] = field(default_factory=dict, repr=False)
    _pairs: deque[tuple[int, float, float]] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._pairs = deque(maxlen=self.capacity)

    def add_predicted(self, stamp_ns: int, value: float) -> None:
        """One predicted sample."""
        partner = self._measured.pop(stamp_ns, None)
        if partner is None:
            self._predicted[stamp_ns] = value
            if len(self._predicted) > self.max_pending:
                del self._predicted[next(iter(self._predicted))]
                self.unpaired_predicted += 1
        else:
            self._pairs.append((stamp_ns, value, partner))
            self.paired += 1

    def add_measured(self, stamp_ns: int, value: float) -> None:
        """One measured sample."""
        partner = self._predicted.pop(stamp_ns, None)
        if partner is None:
            self._measured[stamp_ns] = value
            if len(self._measured) > self.max_pending:
                del self._measured[next(iter(self._measured))]
                self.unpaired_measured += 1
        else:
            self._pairs.append((stamp_ns, partner, value))
            self.paired += 1

    @property
    def pending(self) -> tuple[int, int]:
        """Samples waiting for a partner: ``(predicted, measured)``."""
        return len(self._predicted), len(self._measured)

    def window(self) -> PairedWindow:
        """The paired samples held, sorted by stamp."""
        pairs = sorted(self._pairs)
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
    """Time (s from ``start_ns``) of ``count`` samples ``period_ns`` apart, and ``values``
    (sampled at ``stamps_ns``) linearly interpolated there: exact where no pair is missing."""
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
    """Metrics of the cycle ending at ``cycle_end_ns`` and of the rolling window of
    ``window_cycles`` cycles ending with it, for one channel's paired samples.

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
    """Stamp (ns) of a maximum of the measured signal's fundamental (``1 / period_s``) in
    ``window``: cycles that start there hold both mean crossings well inside them."""
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


# --------------------------------------------------------------------------- replay


@dataclass(frozen=True)
class ReplayResult:
    """One recording replayed through the model and scored."""

    recording: str  # path
    model_file: str
    mean_pressure: float  # Pa, the model's operating point
    samples: int
    duration_s: float  # the recording's span (s)
    replay_s: float  # wall time of the replay (s)
    segments: list[tuple[float, float]]  # steady segments scored (s)
    metrics: dict[str, dict[str, float]]  # channel -> metric -> value

    @property
    def replay_factor(self) -> float:
        """How many times faster than real time the model ran."""
        return self.duration_s / self.replay_s if self.replay_s > 0 else math.inf

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return {
            "recording": self.recording,
            "model_file": self.model_file,
            "mean_pressure": self.mean_pressure,
            "samples": self.samples,
            "duration_s": self.duration_s,
            "segments": [list(s) for s in self.segments],
            "metrics": {channel: dict(values) for channel, values in self.metrics.items()},
        }


def replay_recording(
    recording: Recording,
    model_file: Path | str,
    mean_pressure: float | None = None,
    period_s: float = signals.EXCITATION_PERIOD_S,
) -> ReplayResult:
    """Step the model file's model over the recording's raw ``p_i`` sample by sample (the
    live node's stepper), and score it over the steady segments of the filtered ``p_i``.

    ``mean_pressure`` (Pa) defaults to the recording's mean ``p_i``, as the chain passes it
    to the live node.

    Raises:
        RecordingError: the recording lacks a measured channel.
        SignalError: it holds no steady pulsing (the message names the file).
    """
    measured = recording.measured()
    missing = [key for key, value in measured.items() if value is None]
    if missing:
        raise RecordingError(f"{recording.path}: no measured {', '.join(missing)} to compare with")
    pressure = recording.master_cylinder_pressure
    mean = float(np.mean(pressure)) if mean_pressure is None else mean_pressure
    model = load_model(model_file, mean)
    stepper = model.stepper()
    started = time.perf_counter()
    outputs = np.array([stepper.step(value) for value in pressure.tolist()]).T
    replay_s = time.perf_counter() - started
    time_s = recording.time
    rate = recording.sample_rate
    try:
        segments = signals.steady_segments(time_s, signals.lowpass(pressure, rate), rate, period_s)
    except SignalError as err:
        raise SignalError(f"{recording.path}: {err}") from err
    predicted = dict(zip(OUTPUT_CHANNELS, outputs))
    observed = {key: value for key, value in measured.items() if value is not None}
    return ReplayResult(
        recording=str(recording.path),
        model_file=str(model_file),
        mean_pressure=mean,
        samples=int(pressure.size),
        duration_s=float(time_s[-1] - time_s[0]),
        replay_s=replay_s,
        segments=[(float(a), float(b)) for a, b in segments],
        metrics=score_segments(time_s, predicted, observed, segments, period_s),
    )


def replay_file(
    path: Path,
    model_file: Path,
    reader: Callable[[Path], Recording],
    mean_pressure: float | None = None,
) -> ReplayResult:
    """:func:`replay_recording` of the file ``path`` read by ``reader`` (for process pools)."""
    return replay_recording(reader(path), model_file, mean_pressure)


# --------------------------------------------------------------------------- baseline


class MetricCheck(NamedTuple):
    """One metric of one channel of one recording against its baseline."""

    bag: str
    channel: str
    metric: str
    baseline: float | None  # None: no baseline for it
    value: float
    tolerance: float

    @property
    def delta(self) -> float:
        """Value minus baseline (NaN without a baseline)."""
        return math.nan if self.baseline is None else self.value - self.baseline

    @property
    def status(self) -> str:
        """``ok``, ``MOVED`` (past the tolerance) or ``NEW`` (no baseline)."""
        if self.baseline is None:
            return "NEW"
        return "ok" if abs(self.delta) <= self.tolerance else "MOVED"


def bag_key(path: Path | str, baseline_path: Path) -> str:
    """Name of a recording in a baseline: its path relative to the baseline's folder."""
    path = Path(path).resolve()
    try:
        return path.relative_to(baseline_path.resolve().parent).as_posix()
    except ValueError:
        return path.as_posix()


def load_baseline(path: Path) -> dict[str, Any]:
    """Read a baseline JSON (see :func:`baseline_document`).

    Raises:
        BaselineError: missing, unreadable or malformed file (the message names it).
    """
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError as err:
        raise BaselineError(f"{path}: no such baseline file (write one with --update)") from err
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise BaselineError(f"{path}: unreadable baseline: {err}") from err
    if not isinstance(document, dict) or not isinstance(document.get("bags"), dict):
        raise BaselineError(f"{path}: not a brake_hil baseline (no 'bags' mapping)")
    tolerances = document.get("tolerances", DEFAULT_TOLERANCES)
    if not isinstance(tolerances, dict) or not all(
        isinstance(tolerances.get(k), int | float) for k in METRIC_KEYS
    ):
        raise BaselineError(f"{path}: 'tolerances' must give a number for each of {METRIC_KEYS}")
    for name, entry in document["bags"].items():
        metrics = entry.get("metrics") if isinstance(entry, dict) else None
        if not isinstance(metrics, dict):
            raise BaselineError(f"{path}: bag {name!r} has no 'metrics' mapping")
    return document


def compare_with_baseline(
    results: Mapping[str, ReplayResult],
    baseline: Mapping[str, Any],
) -> list[MetricCheck]:
    """Every metric of every result against ``baseline['bags'][key]['metrics']``."""
    tolerances = {**DEFAULT_TOLERANCES, **baseline.get("tolerances", {})}
    checks = []
    for key, result in results.items():
        stored = baseline.get("bags", {}).get(key, {}).get("metrics", {})
        for channel in OUTPUT_CHANNELS:
            for metric in METRIC_KEYS:
                value = result.metrics[channel][metric]
                reference = stored.get(channel, {}).get(metric)
                checks.append(
                    MetricCheck(
                        key,
                        channel,
                        metric,
                        None if reference is None else float(reference),
                        value,
                        float(tolerances[metric]),
                    )
                )
    return checks


def baseline_document(
    results: Mapping[str, ReplayResult],
    previous: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """A baseline JSON with ``results`` (other bags and tolerances kept from ``previous``)."""
    previous = previous or {}
    bags = dict(previous.get("bags", {}))
    for key, result in results.items():
        bags[key] = result.as_dict()
    document: dict[str, Any] = {
        "about": "brake-hil regress baseline: comparator metrics of each recording replayed "
        "through the model file's model; tolerances are absolute",
        "tolerances": dict(previous.get("tolerances", DEFAULT_TOLERANCES)),
        "bags": dict(sorted(bags.items())),
    }
    if "model_file" in previous:
        document["model_file"] = previous["model_file"]
    return document


# --------------------------------------------------------------------------- the command


def replay_all(
    bags: Sequence[Path],
    model_file: Path,
    reader: Callable[[Path], Recording],
    jobs: int | None = None,
    mean_pressure: float | None = None,
) -> list[ReplayResult]:
    """:func:`replay_file` of every bag, in parallel over a process pool (in order)."""
    workers = max(1, min(jobs or os.cpu_count() or 1, len(bags)))
    if workers == 1:
        return [replay_file(bag, model_file, reader, mean_pressure) for bag in bags]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = [
            pool.submit(replay_file, bag, model_file, reader, mean_pressure) for bag in bags
        ]
        return [future.result() for future in futures]


def format_checks(checks: Sequence[MetricCheck]) -> list[str]:
    """The table ``regress`` prints: one line per bag, channel and metric."""
    width = max([len(c.bag) for c in checks] + [3])
    lines = [
        f"{'bag':{width}s}  {'channel':7s} {'metric':15s}{'baseline':>12s}{'now':>12s}"
        f"{'delta':>11s}{'tol':>9s}  status"
    ]
    for c in checks:
        baseline = "-" if c.baseline is None else f"{c.baseline:.5g}"
        delta = "-" if c.baseline is None else f"{c.delta:+.3g}"
        lines.append(
            f"{c.bag:{width}s}  {c.channel:7s} {c.metric:15s}{baseline:>12s}{c.value:12.5g}"
            f"{delta:>11s}{c.tolerance:9.3g}  {c.status}"
        )
    return lines


def run_regression(
    bags: Sequence[Path],
    baseline_path: Path,
    reader: Callable[[Path], Recording],
    model_file: Path | None = None,
    update: bool = False,
    jobs: int | None = None,
    echo: Callable[[str], None] = print,
) -> int:
    """``brake-hil regress``: replay ``bags``, score, compare with (or ``update``) the baseline.

    Returns the exit status: 0 when every metric is within its tolerance (or the baseline was
    written), 1 when one moved past it or has no baseline yet.

    Raises:
        BaselineError: unusable baseline, no model file, or two bags with one name.
        BrakeHilError: a bad recording or model file (the message names it).
    """
    previous = None if update and not baseline_path.exists() else load_baseline(baseline_path)
    if model_file is None:
        stored = (previous or {}).get("model_file")
        if not isinstance(stored, str):
            raise BaselineError(f"{baseline_path}: names no model file; pass --model")
        model_file = Path(os.path.normpath(baseline_path.parent / stored))
    load_model(model_file)  # a bad model file fails once, here
    keys = [bag_key(bag, baseline_path) for bag in bags]
    if len(set(keys)) != len(keys):
        raise BaselineError(f"{baseline_path}: bags given twice: {sorted(keys)}")
    started = time.perf_counter()
    results = dict(zip(keys, replay_all(bags, model_file, reader, jobs)))
    wall = time.perf_counter() - started
    total = sum(r.duration_s for r in results.values())
    for key, result in results.items():
        echo(
            f"{key}: {result.samples} samples ({result.duration_s:.1f} s) replayed through "
            f"{model_file} at {result.replay_factor:.0f}x real time, "
            f"{len(result.segments)} steady segments scored"
        )
    echo(f"{len(results)} recordings, {total:.1f} s of data in {wall:.2f} s wall time")
    checks = compare_with_baseline(results, previous or {})
    for line in format_checks(checks):
        echo(line)
    if update:
        document = baseline_document(results, previous)
        document["model_file"] = os.path.relpath(model_file, baseline_path.parent)
        baseline_path.parent.mkdir(parents=True, exist_ok=True)
        baseline_path.write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")
        echo(f"baseline written to {baseline_path}")
        return 0
    moved = [c for c in checks if c.status != "ok"]
    if moved:
        echo(f"{len(moved)} metrics moved past their tolerance or have no baseline")
        return 1
    echo("every metric within its tolerance")
    return 0
