"""``brake-hil regress``: recordings replayed through a model, held against a baseline.

The comparator's metrics of each recording, replayed through a model file faster than real
time, are compared with a stored baseline (ROS-free).

The scoring is the comparator node's (:mod:`brake_hil.analysis.stamp_scoring`), so the node
and this command agree: the live model steps on raw ``p_i``; its output and the measurements
are low-passed alike (the model is linear, so filtering its output equals filtering its
input) and compared with the paper's Table 4-5 metrics over the steady 5 Hz cycles, which match
``brake-hil compare`` up to the filter's edge effects and the operating point (``compare``
derives the model at each segment's own mean pressure, the live model at one).

* :func:`replay_recording`: a recording through the live model's per-sample stepper (the
  node's code path, faster than real time), scored over the recording's steady segments.
* :func:`compare_with_baseline`: metric by metric against a stored baseline, with absolute
  tolerances; :func:`load_baseline` / :func:`baseline_document` read and write its JSON.
* :func:`run_regression` is the command: bags replayed over
  :func:`~brake_hil.app.parallel.parallel_map`, the baseline compared or rewritten; it
  prints nothing and returns a :class:`Regression`.

Baseline JSON: ``{"model_file": path relative to the baseline's folder, "tolerances":
{metric: absolute tolerance}, "bags": {name: {"metrics": {channel: {metric: value}}, ...}}}``,
a bag named by its path relative to the baseline's folder.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
import json
import math
import os
from pathlib import Path
import time
from typing import Any, NamedTuple

import numpy as np

from brake_hil.analysis import signals
from brake_hil.analysis.recording import Recording
from brake_hil.analysis.stamp_scoring import (
    DEFAULT_TOLERANCES,
    METRIC_KEYS,
    score_segments,
)
from brake_hil.app.parallel import ONE_PER_CORE, Outcome, Workers, parallel_map, values
from brake_hil.errors import BaselineError, NoSteadyPulsingError, RecordingError, SignalError
from brake_hil.io.recording_reader import read_recording
from brake_hil.live.model_file import load_model
from brake_hil.physics.lti_model import SAMPLE_TIME
from brake_hil.topics import OUTPUT_CHANNELS

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
    """Replay a recording through a model file's live stepper and score it.

    The model steps over the recording's raw ``p_i`` sample by sample (the live node's
    stepper) and is scored over the steady segments of the filtered ``p_i``.

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
    live_rate = 1.0 / SAMPLE_TIME
    if abs(recording.sample_rate / live_rate - 1.0) > 0.01:
        raise RecordingError(
            f"{recording.path}: sampled at {recording.sample_rate:.4g} Hz; the live model "
            f"steps at {live_rate:g} Hz, so its replay would run at the wrong time scale"
        )
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
        raise type(err)(f"{recording.path}: {err}") from err
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
    reader: Callable[[Path], Recording] = read_recording,
    workers: Workers = ONE_PER_CORE,
    mean_pressure: float | None = None,
    progress: Callable[[Outcome[ReplayResult]], None] | None = None,
) -> list[ReplayResult]:
    """:func:`replay_file` of every bag over :func:`~brake_hil.app.parallel.parallel_map`.

    Args:
        bags: recordings to replay.
        model_file: the model file every bag is replayed through.
        reader: reads a recording (must pickle: a module-level function).
        workers: where the bags are replayed (:class:`~brake_hil.app.parallel.Workers`).
        mean_pressure: the model's operating point (Pa); default each recording's mean ``p_i``.
        progress: called with each bag's outcome as it finishes (in the order they finish).

    Returns:
        One result per bag, in order.

    Raises:
        BrakeHilError: the first bag (in order) that could not be replayed; the others were.
    """
    replay = partial(
        replay_file, model_file=model_file, reader=reader, mean_pressure=mean_pressure
    )
    return values(parallel_map(replay, bags, workers, progress))


@dataclass(frozen=True)
class Regression:
    """What ``brake-hil regress`` found: each bag's replay and its metrics against the baseline."""

    baseline_path: Path
    model_file: Path
    results: dict[str, ReplayResult]  # bag key (see :func:`bag_key`) -> replay
    skipped: dict[str, str]  # bag key -> why: recordings without steady pulsing, not scored
    lost: tuple[str, ...]  # skipped bags the baseline holds: they no longer score (moved)
    checks: tuple[MetricCheck, ...]  # every metric of every bag against the baseline
    wall_s: float  # wall time of all replays (s)
    updated: bool  # the baseline was (re)written with these results

    @property
    def data_s(self) -> float:
        """Seconds of recorded data replayed, over every bag."""
        return sum(result.duration_s for result in self.results.values())

    @property
    def moved(self) -> tuple[MetricCheck, ...]:
        """Checks past their tolerance or without a baseline."""
        return tuple(check for check in self.checks if check.status != "ok")

    @property
    def failed(self) -> bool:
        """A metric moved, or a bag of the baseline could not be scored."""
        return bool(self.moved or self.lost)


def run_regression(
    bags: Sequence[Path],
    baseline_path: Path,
    model_file: Path | None = None,
    update: bool = False,
    workers: Workers = ONE_PER_CORE,
    progress: Callable[[Outcome[ReplayResult]], None] | None = None,
    reader: Callable[[Path], Recording] = read_recording,
) -> Regression:
    """``brake-hil regress``: replay ``bags``, score, compare with (or ``update``) the baseline.

    Args:
        bags: recordings to replay.
        baseline_path: the baseline JSON (written when ``update``).
        model_file: the model file; default the baseline's.
        update: rewrite the baseline with these results instead of only comparing.
        workers: where the bags are replayed (:class:`~brake_hil.app.parallel.Workers`).
        progress: called with each bag's outcome as it finishes (in the order they finish).
        reader: reads a recording (must pickle: a module-level function).

    A recording without steady 5 Hz pulsing (a ramp, a sweep) has nothing to score: it is
    skipped (:attr:`Regression.skipped`, with the reason) and never written to the baseline;
    one the baseline holds is :attr:`Regression.lost`, a failure.

    Returns:
        The replays and their checks; the command exits 0 when the baseline was written or
        nothing moved or was lost (:attr:`Regression.failed`), else 1.

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
    replay = partial(replay_file, model_file=model_file, reader=reader, mean_pressure=None)
    outcomes = parallel_map(replay, bags, workers, progress)
    wall = time.perf_counter() - started
    results: dict[str, ReplayResult] = {}
    skipped: dict[str, str] = {}
    for key, outcome in zip(keys, outcomes):
        if isinstance(outcome.error, NoSteadyPulsingError):
            skipped[key] = str(outcome.error)
        else:
            results[key] = outcome.unwrap()
    lost = tuple(key for key in skipped if key in (previous or {}).get("bags", {}))
    checks = compare_with_baseline(results, previous or {})
    if update:
        document = baseline_document(results, previous)
        document["model_file"] = os.path.relpath(model_file, baseline_path.parent)
        baseline_path.parent.mkdir(parents=True, exist_ok=True)
        baseline_path.write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")
    return Regression(
        baseline_path, model_file, results, skipped, lost, tuple(checks), wall, update
    )
