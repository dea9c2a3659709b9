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
  tolerances, then segment by segment (:mod:`~brake_hil.app.regress_segments`: every
  segment a replay holds is scored, pulsing, sweep, ramp, step, hold or modulated);
  :func:`load_baseline` / :func:`baseline_document` read and write its JSON.
* :func:`plan_replays` says which recordings the paths name and which model file each is
  replayed through: ``--model`` for all, else the baseline's model file when it names one,
  else each recording's own rig file (``RECORDING.rig.yaml`` beside it, as ``diagnose`` finds
  it). A path that holds no recording, or a recording with no rig file beside it, is
  skipped with its reason; a path that does not exist is refused.
* :func:`run_regression` is the command: bags replayed over
  :func:`~brake_hil.app.parallel.parallel_map`, the baseline compared or rewritten; it
  prints nothing and returns a :class:`Regression`.
* :func:`far_off`: a baseline that is itself far from the recording (a ptp ratio further
  from 100 % than the rig file's tolerances allow, :func:`rig_spread`) is flagged: a
  regression that holds still against it only says the wrong answer has not changed.

Baseline JSON: ``{"model_file": path relative to the baseline's folder (only when one model
file was given for all), "tolerances": {metric: absolute tolerance}, "bags": {name:
{"model_file": the model file it was replayed through, relative to the baseline's folder,
"metrics": {channel: {metric: value}}, "segment_metrics": [{"kind", "t_start", "t_end",
"metrics": {channel: {metric: value}}, ...}], ...}}}``, a bag named by its path relative to
the baseline's folder; a bag without ``segment_metrics`` (written before they were kept) is
checked on its ``metrics`` alone.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
import json
import math
import os
from pathlib import Path
import time
from typing import Any, Final, NamedTuple

import numpy as np

from brake_hil.analysis import signals
from brake_hil.analysis.recording import Recording
from brake_hil.analysis.segment_comparison import score_prediction
from brake_hil.analysis.stamp_scoring import (
    DEFAULT_TOLERANCES,
    METRIC_KEYS,
    Thresholds,
    score_segments,
)
from brake_hil.app.parallel import ONE_PER_CORE, Outcome, Workers, parallel_map, values
from brake_hil.app.regress_plan import Plan, plan_replays, rig_spread
from brake_hil.app.regress_segments import segment_checks
from brake_hil.diagnosis.rig_findings import FLAG_SIGMAS
from brake_hil.errors import (
    BaselineError,
    NoSteadyPulsingError,
    RecordingError,
    SignalError,
)
from brake_hil.io.recording_reader import read_recording
from brake_hil.live.model_file import load_model
from brake_hil.physics.lti_model import SAMPLE_TIME
from brake_hil.topics import OUTPUT_CHANNELS

FAR_OFF_PTP_PCT: Final = Thresholds().ptp_ratio_error_pct
"""Without the rig's own spread of the ptp ratio (no rig file, no steady pulsing), a baseline
whose ptp ratio of a channel is further than this from 100 % (percentage points) is itself
far off: the comparator's ERROR level, where the live comparator calls the model wrong."""

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
    basis: str = "steady_cycles"  # or non_idle_segments: a recording without steady pulsing
    scored_segments: list[dict[str, Any]] = field(default_factory=list)  # every segment's
    # channel -> one-sigma spread (percentage points) of the ptp ratio the rig file's
    # tolerances allow (:func:`~brake_hil.diagnosis.ptp_spread.ptp_spread`); empty: unknown
    ptp_spread: dict[str, float] = field(default_factory=dict)

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
            "basis": self.basis,
            **({"segment_metrics": self.scored_segments} if self.scored_segments else {}),
            **({"ptp_spread_pct": dict(self.ptp_spread)} if self.ptp_spread else {}),
        }


def replay_recording(
    recording: Recording,
    model_file: Path | str,
    mean_pressure: float | None = None,
    period_s: float = signals.EXCITATION_PERIOD_S,
) -> ReplayResult:
    """Replay a recording through a model file's live stepper and score it.

    The model steps over the recording's raw ``p_i`` sample by sample (the live node's
    stepper) and is scored over the steady segments of the filtered ``p_i``, and every
    segment it holds on its own (``scored_segments``: a procedure's sweep and ramps too); a
    recording without steady pulsing (a ramp, a sweep) is scored per segment, its metrics
    over its non-idle segments (:func:`replay_any`).

    ``mean_pressure`` (Pa) defaults to the recording's mean ``p_i``, as the chain passes it
    to the live node.

    Raises:
        RecordingError: the recording lacks a measured channel.
        NoSteadyPulsingError: nothing but idle (the message names the file).
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
    predicted = dict(zip(OUTPUT_CHANNELS, outputs))
    try:
        segments = signals.steady_segments(time_s, signals.lowpass(pressure, rate), rate, period_s)
    except NoSteadyPulsingError:
        return replay_any(recording, str(model_file), mean, predicted, replay_s, period_s)
    except SignalError as err:
        raise type(err)(f"{recording.path}: {err}") from err
    observed = {key: value for key, value in measured.items() if value is not None}
    every = score_prediction(recording, predicted, 1.0 / period_s, mean).segments
    return ReplayResult(
        recording=str(recording.path),
        model_file=str(model_file),
        mean_pressure=mean,
        samples=int(pressure.size),
        duration_s=float(time_s[-1] - time_s[0]),
        replay_s=replay_s,
        segments=[(float(a), float(b)) for a, b in segments],
        metrics=score_segments(time_s, predicted, observed, segments, period_s),
        scored_segments=[s.as_dict(response=False) for s in every],
    )


def replay_any(
    recording: Recording,
    model_file: str,
    mean: float,
    predicted: dict[str, np.ndarray],
    replay_s: float,
    period_s: float,
) -> ReplayResult:
    """A replay without steady pulsing scored on every segment, as ``compare`` scores it.

    Raises:
        NoSteadyPulsingError: nothing but idle to score (the message names the file).
    """
    try:
        scored = score_prediction(recording, predicted, 1.0 / period_s, mean)
    except SignalError as err:
        raise NoSteadyPulsingError(f"{recording.path}: nothing to score: {err}") from err
    return ReplayResult(
        recording=str(recording.path),
        model_file=model_file,
        mean_pressure=mean,
        samples=int(recording.time.size),
        duration_s=float(recording.time[-1] - recording.time[0]),
        replay_s=replay_s,
        segments=[],
        metrics=scored.metrics(),
        basis=scored.basis,
        scored_segments=[s.as_dict(response=False) for s in scored.segments],
    )


def replay_file(
    path: Path,
    model_file: Path,
    reader: Callable[[Path], Recording],
    mean_pressure: float | None = None,
) -> ReplayResult:
    """:func:`replay_recording` of the file ``path`` read by ``reader`` (for process pools).

    With the ptp spread its rig file's tolerances allow (:func:`.regress_plan.rig_spread`).
    """
    recording = reader(path)
    result = replay_recording(recording, model_file, mean_pressure)
    return replace(result, ptp_spread=rig_spread(recording, path, model_file))


def replay_job(job: tuple[Path, Path], reader: Callable[[Path], Recording]) -> ReplayResult:
    """:func:`replay_file` of a ``(recording, model file)`` pair (for process pools)."""
    return replay_file(job[0], job[1], reader)


def far_off(
    metrics: Mapping[str, Mapping[str, float]], spread: Mapping[str, float] | None = None
) -> list[str]:
    """``"F_k ptp 180.8 % (100 ± 30 % allowed)"`` for each channel far from 100 %, or not a number.

    Far: further than :data:`FLAG_SIGMAS` times the ``spread`` the rig file's tolerances allow
    (:func:`rig_spread`), the diagnosis's bar for a value outside its tolerance; without a
    spread, further than :data:`FAR_OFF_PTP_PCT`.
    """
    found = []
    for channel in OUTPUT_CHANNELS:
        ratio = float(metrics.get(channel, {}).get("ptp_ratio_pct", math.nan))
        allowed = FAR_OFF_PTP_PCT
        if spread and channel in spread:
            allowed = FLAG_SIGMAS * spread[channel]
        if not math.isfinite(ratio) or abs(ratio - 100.0) > allowed:
            found.append(f"{channel} ptp {ratio:.1f} % (100 ± {allowed:.0f} % allowed)")
    return found


# --------------------------------------------------------------------------- baseline


class MetricCheck(NamedTuple):
    """One metric of one channel of one recording against its baseline."""

    bag: str
    channel: str
    metric: str
    baseline: float | None  # None: no baseline for it
    value: float
    tolerance: float
    segment: str = ""  # a segment's metric: which (``sweep 11.0-21.0 s``); "": the bag's
    note: str = ""  # LOST: a segment of the baseline the replay no longer holds

    @property
    def delta(self) -> float:
        """Value minus baseline (NaN without a baseline)."""
        return math.nan if self.baseline is None else self.value - self.baseline

    @property
    def status(self) -> str:
        """``ok``, ``MOVED`` (past the tolerance), ``NEW`` (no baseline) or ``LOST``."""
        if self.note:
            return self.note
        if self.baseline is None:
            return "NEW"
        return "ok" if abs(self.delta) <= self.tolerance else "MOVED"


def bag_key(path: Path | str, baseline_path: Path) -> str:
    """Name of a recording (or model file) in a baseline.

    Its path relative to the baseline's folder, or its absolute path when outside it.
    """
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
    """Every metric of every result against ``baseline['bags'][key]['metrics']``.

    Then each segment's (:func:`~brake_hil.app.regress_segments.segment_checks`) against
    the bag's ``segment_metrics``, when the baseline keeps them.
    """
    tolerances = {**DEFAULT_TOLERANCES, **baseline.get("tolerances", {})}
    checks = []
    for key, result in results.items():
        entry = baseline.get("bags", {}).get(key, {})
        stored = entry.get("metrics", {})
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
        rows = segment_checks(result.scored_segments, entry.get("segment_metrics"), tolerances)
        for segment, channel, metric, reference, value, tolerance, note in rows:
            checks.append(
                MetricCheck(key, channel, metric, reference, value, tolerance, segment, note)
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
        "through its model file (its own rig file beside it, unless one model_file is given "
        "for all); paths relative to this file's folder; tolerances are absolute",
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
    model_file: Path | None  # the one model file of every bag (--model or the baseline's)
    results: dict[str, ReplayResult]  # bag key (see :func:`bag_key`) -> replay
    skipped: dict[str, str]  # bag key -> why: recordings with nothing to score
    lost: tuple[str, ...]  # skipped bags the baseline holds: they no longer score (moved)
    checks: tuple[MetricCheck, ...]  # every metric of every bag against the baseline
    wall_s: float  # wall time of all replays (s)
    updated: bool  # the baseline was (re)written with these results
    refused: dict[str, str] = field(default_factory=dict)  # path -> why it was not replayed
    sources: dict[str, str] = field(default_factory=dict)  # bag key -> where its model came from
    far_off: dict[str, list[str]] = field(default_factory=dict)  # bag key -> far-off channels
    # bag key -> the model file the far-off metrics were measured with (the stored baseline's)
    far_off_models: dict[str, str] = field(default_factory=dict)

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


def _stored_model(previous: Mapping[str, Any] | None, baseline_path: Path) -> Path | None:
    """The baseline's one model file (``model_file`` at its top), or ``None``."""
    stored = (previous or {}).get("model_file")
    if stored is None:
        return None
    if not isinstance(stored, str):
        raise BaselineError(f"{baseline_path}: 'model_file' must be a path")
    return Path(os.path.normpath(baseline_path.parent / stored))


def _write_baseline(
    path: Path,
    results: Mapping[str, ReplayResult],
    previous: Mapping[str, Any] | None,
    model_file: Path | None,
) -> None:
    """Write the baseline: each bag with the model file it used, relative to ``path``'s folder."""
    document = baseline_document(results, previous)
    for key, result in results.items():
        document["bags"][key]["model_file"] = bag_key(result.model_file, path)
    document.pop("model_file", None)
    if model_file is not None:
        document["model_file"] = bag_key(model_file, path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")


def _scored(
    keys: Sequence[str], outcomes: Sequence[Outcome[ReplayResult]]
) -> tuple[dict[str, ReplayResult], dict[str, str]]:
    """The replays by bag key, and the bags skipped for want of anything to score (why).

    Raises:
        BrakeHilError: the first bag (in order) that failed otherwise.
    """
    results: dict[str, ReplayResult] = {}
    skipped: dict[str, str] = {}
    for key, outcome in zip(keys, outcomes):
        if isinstance(outcome.error, NoSteadyPulsingError):
            skipped[key] = str(outcome.error)
        else:
            results[key] = outcome.unwrap()
    return results, skipped


def _far_off_baselines(
    results: Mapping[str, ReplayResult], held: Mapping[str, Any] | None, baseline_path: Path
) -> tuple[dict[str, list[str]], dict[str, str]]:
    """:func:`far_off` of each baseline, and the model file its metrics were measured with.

    The results just written (``held`` ``None``), or the stored baseline of each bag replayed
    (its ``model_file``, relative to the baseline's folder, when it names one).
    """
    if held is None:
        metrics = {key: result.metrics for key, result in results.items()}
    else:
        metrics = {key: held[key]["metrics"] for key in results if key in held}
    flagged = {
        key: found
        for key, value in metrics.items()
        if (found := far_off(value, results[key].ptp_spread))
    }
    stored = held or {}
    models = {
        key: os.path.normpath(baseline_path.parent / str(stored[key]["model_file"]))
        if "model_file" in stored.get(key, {})
        else str(results[key].model_file)
        for key in flagged
    }
    return flagged, models


def run_regression(
    bags: Sequence[Path],
    baseline_path: Path,
    model_file: Path | None = None,
    update: bool = False,
    workers: Workers = ONE_PER_CORE,
    progress: Callable[[Outcome[ReplayResult]], None] | None = None,
    reader: Callable[[Path], Recording] = read_recording,
    start: Callable[[Plan], None] | None = None,
) -> Regression:
    """``brake-hil regress``: replay ``bags``, score, compare with (or ``update``) the baseline.

    Args:
        bags: recordings, or folders of them, to replay.
        baseline_path: the baseline JSON (written when ``update``).
        model_file: one model file for every recording; default the baseline's when it names
            one, else each recording's own rig file (``RECORDING.rig.yaml`` beside it).
        update: rewrite the baseline with these results instead of only comparing (a new
            file is made).
        workers: where the bags are replayed (:class:`~brake_hil.app.parallel.Workers`).
        progress: called with each bag's outcome as it finishes (in the order they finish).
        reader: reads a recording (must pickle: a module-level function).
        start: called with the plan once the inputs are checked, before the replays.

    A path that holds no recording, or a recording without its rig file, is
    :attr:`Regression.refused` (one the baseline holds is lost). A recording without steady
    pulsing (a ramp, a sweep) is scored per segment (:func:`replay_any`); one with nothing
    but idle is skipped (:attr:`Regression.skipped`, with the reason) and never written to
    the baseline; one the baseline holds is :attr:`Regression.lost`, a failure.

    Returns:
        The replays, their checks and the far-off baselines (:func:`far_off`: of the
        results when ``update``, else of the stored baseline).

    Raises:
        BaselineError: unusable baseline, or two bags with one name.
        BrakeHilError: a path that does not exist, nothing left to replay, a bad recording
            or model file (the message names it).
    """
    previous = None if update and not baseline_path.exists() else load_baseline(baseline_path)
    stored = None if model_file is not None else _stored_model(previous, baseline_path)
    plan = plan_replays(bags, model_file, stored)
    if not plan.jobs:
        reasons = "; ".join(plan.refused.values())
        raise BaselineError(f"{baseline_path}: no recording to replay: {reasons}")
    for model in dict.fromkeys(model for _, model in plan.jobs):
        load_model(model)  # a bad model file fails once, here
    keys = [bag_key(bag, baseline_path) for bag, _ in plan.jobs]
    if len(set(keys)) != len(keys):
        raise BaselineError(f"{baseline_path}: bags given twice: {sorted(keys)}")
    if start is not None:
        start(plan)
    started = time.perf_counter()
    outcomes = parallel_map(partial(replay_job, reader=reader), plan.jobs, workers, progress)
    wall = time.perf_counter() - started
    results, skipped = _scored(keys, outcomes)
    held = (previous or {}).get("bags", {})
    refused_keys = [bag_key(path, baseline_path) for path in plan.refused]
    lost = tuple(key for key in [*skipped, *refused_keys] if key in held)
    checks = compare_with_baseline(results, previous or {})
    if update:
        _write_baseline(baseline_path, results, previous, model_file or stored)
    flagged, measured_with = _far_off_baselines(results, None if update else held, baseline_path)
    sources = {key: plan.sources[bag] for key, (bag, _) in zip(keys, plan.jobs)}
    one_model = model_file or stored
    return Regression(
        baseline_path,
        one_model,
        results,
        skipped,
        lost,
        tuple(checks),
        wall,
        update,
        plan.refused,
        sources,
        flagged,
        measured_with,
    )
