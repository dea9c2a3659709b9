"""What a chain run produced, and the recorded predictions checked against the batch model.

No rclpy.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
import json
import math
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from brake_hil.errors import RecordingError
from brake_hil.io.recording_reader import list_topics, read_recording
from brake_hil.live.model import LiveModel
from brake_hil.runtime.timing import format_us
from brake_hil.topics import MASTER_CYLINDER_PRESSURE, OUTPUT_CHANNELS, PREDICTED_OUTPUTS

__all__ = [
    "ChainResult",
    "Judgement",
    "LoopLimits",
    "check_recorded_predictions",
    "judge_cycles",
    "judge_loop",
    "judge_real_time",
    "read_json",
    "verdict",
]


@dataclass(frozen=True)
class ChainResult:
    """What a chain run produced."""

    out_dir: Path
    comparator: dict[str, Any] | None = None  # comparator summary
    model: dict[str, Any] | None = None  # caliper model timing statistics
    bag: Path | None = None  # the recorder's MCAP directory
    check: dict[str, float] | None = None  # recorded predictions against the batch model
    missing: tuple[str, ...] = ()  # nodes not available
    exit_codes: dict[str, int] = field(default_factory=dict)
    cpu_s: dict[str, float] = field(default_factory=dict)  # CPU time of each node (s)
    wall_s: float = 0.0  # from the source's start to the stop (s)
    logs: Path | None = None  # the nodes' log files
    source: dict[str, Any] | None = None  # pressure source summary
    expected: int | None = None  # input samples the source was to publish (None: unknown)
    expected_cycles: dict[str, int] | None = None  # steady cycles the recording holds
    schedule_s: float | None = None  # the replay's length at its rate (s; None: unknown)
    load: tuple[float, int] | None = None  # 1-minute load average at the end, and CPU cores

    @property
    def failed(self) -> dict[str, int]:
        """Nodes that exited with a non-zero status, and the status."""
        return {name: code for name, code in self.exit_codes.items() if code != 0}

    def sample_losses(self) -> tuple[bool, str]:
        """Whether every input sample was predicted and recorded, and one line saying so.

        Counts the source's published ``p_i`` samples against the run's (``expected``: a
        source stopped before the end of its run, by a timeout on a starved machine, is a
        failure), the model's predictions and, with a recording, the recorded inputs and
        predictions. Without the source's or the model's summary nothing can be said: that is a
        failure too ("I don't know").
        """
        if self.source is None or self.model is None:
            absent = [n for n, d in (("source", self.source), ("model", self.model)) if d is None]
            absent_text = " or ".join(absent)
            return False, f"cannot tell whether samples were lost: no {absent_text} summary"
        published = int(self.source["published"])
        predictions = int(self.model["counters"]["predictions"])
        unpredicted = published - predictions
        short = self.expected is not None and published != self.expected
        of_run = f" of the run's {self.expected}" if short else ""
        parts = [f"{published}{of_run} samples published, {predictions} predicted"]
        parts[0] += f" ({unpredicted} unpredicted)" if unpredicted else ""
        lost = 0
        if self.check is not None:
            inputs, recorded = int(self.check["inputs"]), int(self.check["predictions"])
            lost = (published - inputs) + (predictions - recorded)
            parts.append(f"{inputs} inputs and {recorded} predictions recorded ({lost} lost)")
        elif self.bag is not None:
            return False, f"{parts[0]}; the recording could not be checked"
        whole = unpredicted == 0 and lost == 0
        verdict = "every sample predicted and recorded" if whole else "samples were lost"
        if short and whole:
            verdict = "the run was cut short"
        ok = whole and not short
        return ok, f"{verdict}: " + "; ".join(parts)

    def judgements(self) -> list[Judgement]:
        """The run judged: samples, steady cycles, real time, the model loop's timing."""
        comparator = self.comparator
        scored = unpaired = None
        if comparator is not None and isinstance(comparator.get("metrics"), dict):
            metrics = comparator["metrics"]
            scored = {c: int(e.get("cycles", 0)) for c, e in metrics.items()}
            unpaired = {c: e.get("unpaired_reasons", {}) for c, e in metrics.items()}
        model, source = self.model or {}, self.source or {}
        latency, period = model.get("latency", {}), model.get("period_error", {})
        replay = source.get("period_error", {})
        return [
            judge_samples(*self.sample_losses()),
            judge_cycles(scored, self.expected_cycles, unpaired),
            judge_real_time(
                self.schedule_s, _seconds(replay.get("max_us")), _seconds(latency.get("max_us"))
            ),
            judge_loop(
                period.get("p99_us"),
                latency.get("p99_us"),
                ceiling_us=float(latency.get("ceiling_us", math.inf)),
                load=self.load,
            ),
        ]

    def verdict(self) -> tuple[int, list[str], list[str]]:
        """Exit status, the lines that hold and the lines that fail (:func:`verdict`)."""
        return verdict(self.judgements(), self.failed)


def _seconds(value_us: float | None) -> float | None:
    """Microseconds to seconds; None stays None."""
    return None if value_us is None else float(value_us) / 1e6


def read_json(path: Path) -> dict[str, Any] | None:
    """The JSON object in ``path``; None when it is missing, unreadable or not an object."""
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return document if isinstance(document, dict) else None


def check_recorded_predictions(bag: Path, model: LiveModel) -> dict[str, float]:
    """Recorded predictions against the batch ``model`` (the run's) on the recorded ``p_i``.

    Returns the input and prediction counts (from the files' indexes, so a recording that lost
    samples is counted, not refused) and, when they agree, per channel the largest deviation
    over the batch output's peak-to-peak (float rounding: ~1e-13).
    """
    topics = {t.name: t for t in list_topics(bag)}
    missing = [
        spec.name
        for spec in (MASTER_CYLINDER_PRESSURE, PREDICTED_OUTPUTS[0])
        if spec.name not in topics
    ]
    check: dict[str, float] = (
        {
            "inputs": float(topics[MASTER_CYLINDER_PRESSURE.name].message_count),
            "predictions": float(topics[PREDICTED_OUTPUTS[0].name].message_count),
        }
        if not missing
        else {"inputs": 0.0, "predictions": 0.0}
    )
    if missing or check["inputs"] != check["predictions"]:
        return check  # samples missing from the recording: counted, nothing more to compare
    try:
        recorded = read_recording(bag, required=(MASTER_CYLINDER_PRESSURE, *PREDICTED_OUTPUTS))
    except RecordingError:
        return check  # e.g. a gap where both lost the same samples: the counts say it
    batch = model.batch(recorded.master_cylinder_pressure)
    predicted = (
        recorded.predicted_bore_pressure,
        recorded.predicted_block_force,
        recorded.predicted_caliper_displacement,
    )
    for channel, live, offline in zip(OUTPUT_CHANNELS, predicted, batch):
        assert live is not None
        check[f"max_dev_{channel}"] = float(np.max(np.abs(live - offline)) / np.ptp(offline))
    return check


# --------------------------------------------------------------------------- the verdict

OK, WARN, ERROR = 0, 1, 2
"""Levels, as ``diagnostic_msgs/msg/DiagnosticStatus``: WARN is said and holds, ERROR fails."""
LEVEL_NAMES = ("OK", "WARN", "ERROR")
MIN_CYCLE_SHARE = 0.9
"""A channel with fewer steady cycles scored than this share of the recording's fails."""
REALTIME_LAG_S = 1.0
"""A replay further behind its schedule than this, or a model further behind its input (s),
is not a real-time run."""


class LoopLimits(NamedTuple):
    """Where the caliper model's p99 period error and latency (us) turn WARN and ERROR.

    The node's own levels (``CaliperModelSettings`` defaults): its loop WARNs on a tick over
    1 ms late (``LATE_TICK_NS``); its input is LATE (WARN) after ``input_late_ms`` (5 ms) and
    SILENT (ERROR) after ``input_silent_ms`` (50 ms) without a sample: a prediction that late
    is as late to its consumers.
    """

    period_warn_us: float = 1_000.0
    period_error_us: float = 50_000.0
    latency_warn_us: float = 5_000.0
    latency_error_us: float = 50_000.0


LOOP_LIMITS = LoopLimits()
"""The caliper model's default limits."""


class Judgement(NamedTuple):
    """One judgement of a chain run: its level and one line naming what was found."""

    level: int
    line: str


def judge_samples(complete: bool, line: str) -> Judgement:
    """The sample counts (:meth:`ChainResult.sample_losses`) as a judgement."""
    return Judgement(OK if complete else ERROR, line)


def judge_cycles(
    scored: Mapping[str, int] | None,
    expected: Mapping[str, int] | None,
    unpaired: Mapping[str, Mapping[str, int]] | None = None,
) -> Judgement:
    """Steady cycles scored per channel against those the recording holds (``expected``).

    ERROR when a channel scored fewer than :data:`MIN_CYCLE_SHARE` of its expected cycles, or
    none with no expectation known, or when the counts are missing; WARN when the recording
    holds no steady cycle (nothing to compare). ``unpaired``: the comparator's unpaired
    samples by reason per channel, said as the why.
    """
    if scored is None:
        return Judgement(ERROR, "cannot tell what was compared: no comparator summary")
    if expected is None:
        counts = ", ".join(f"{c} {n}" for c, n in scored.items())
        if all(scored.values()):
            return Judgement(OK, f"steady cycles scored: {counts}")
        return Judgement(ERROR, f"a channel compared nothing: steady cycles scored {counts}")
    if not any(expected.values()):
        return Judgement(WARN, "nothing compared: the recording holds no steady 5 Hz cycle")
    counts = ", ".join(f"{c} {scored.get(c, 0)} of {n}" for c, n in expected.items())
    short = [c for c, n in expected.items() if scored.get(c, 0) < MIN_CYCLE_SHARE * n]
    if not short:
        return Judgement(OK, f"steady cycles scored: {counts}")
    line = (
        f"too few steady cycles scored ({', '.join(short)} under "
        f"{MIN_CYCLE_SHARE:.0%} of those the recording holds): {counts}"
    )
    return Judgement(ERROR, line + _unpaired_text(unpaired, short))


def _unpaired_text(unpaired: Mapping[str, Mapping[str, int]] | None, short: list[str]) -> str:
    """Why cycles went unscored, as far as pairing tells: the unpaired samples by reason."""
    if not unpaired:
        return ""
    words = {
        "behind": "no partner within the horizon",
        "mismatch": "stamps that never matched",
        "end": "partner still missing at the end",
    }
    parts = []
    for channel in short:
        reasons = unpaired.get(channel, {})
        said = ", ".join(f"{n} {words.get(r, r)}" for r, n in reasons.items() if n)
        said = f" ({said})" if said else ""
        parts.append(f"{channel} {sum(reasons.values())} unpaired{said}")
    return "; " + "; ".join(parts)


def judge_real_time(
    schedule_s: float | None, replay_lag_s: float | None, model_lag_s: float | None
) -> Judgement:
    """Did the run keep real time: the replay against its schedule, the model against its input.

    ``schedule_s``: the recording's length over the rate; ``replay_lag_s``: the most the
    source published behind its schedule (None or NaN: a live source, no schedule);
    ``model_lag_s``: the most a prediction came after its input (the model's latency). Past
    :data:`REALTIME_LAG_S` is ERROR; without the model's figure, ERROR ("cannot tell").
    """
    if model_lag_s is None or not math.isfinite(model_lag_s):
        return Judgement(ERROR, "cannot tell whether the run kept real time: no model latency")
    parts = []
    late = model_lag_s > REALTIME_LAG_S
    if schedule_s is not None and replay_lag_s is not None and math.isfinite(replay_lag_s):
        parts.append(
            f"the replay ran up to {format_us(replay_lag_s * 1e6)} behind its "
            f"{schedule_s:.1f} s schedule"
        )
        late = late or replay_lag_s > REALTIME_LAG_S
    parts.append(f"the model ran up to {format_us(model_lag_s * 1e6)} behind its input")
    if late:
        return Judgement(ERROR, "not a real-time run: " + "; ".join(parts))
    return Judgement(OK, "real time kept: " + "; ".join(parts))


def judge_loop(
    period_p99_us: float | None,
    latency_p99_us: float | None,
    limits: LoopLimits = LOOP_LIMITS,
    ceiling_us: float = math.inf,
    load: tuple[float, int] | None = None,
) -> Judgement:
    """The caliper model's p99 period error and latency against ``limits``: OK, WARN, ERROR.

    Past OK, the line says how busy the machine was (``load``: the 1-minute load average and
    the CPU cores), the first thing to look at when a 1 kHz loop falls behind.
    """
    if period_p99_us is None or latency_p99_us is None:
        return Judgement(ERROR, "cannot tell the loop's timing: no model summary")
    levels = (
        _level(period_p99_us, limits.period_warn_us, limits.period_error_us),
        _level(latency_p99_us, limits.latency_warn_us, limits.latency_error_us),
    )
    level = max(levels)
    period = format_us(period_p99_us, ceiling_us)
    latency = format_us(latency_p99_us, ceiling_us)
    line = (
        f"loop timing {LEVEL_NAMES[level]}: period error p99 {period} "
        f"({LEVEL_NAMES[levels[0]]}; WARN past {format_us(limits.period_warn_us)}, ERROR past "
        f"{format_us(limits.period_error_us)}), latency p99 {latency} "
        f"({LEVEL_NAMES[levels[1]]}; WARN past {format_us(limits.latency_warn_us)}, "
        f"ERROR past {format_us(limits.latency_error_us)})"
    )
    if level > OK and load is not None:
        average, cores = load
        busy = "busy: other work took the CPU the loop needed" if average >= cores else "not busy"
        line += (
            f"; the machine's load average was {average:.1f} on {cores} cores, the chain's own "
            f"nodes included ({busy})"
        )
    return Judgement(level, line)


def _level(value: float, warn: float, error: float) -> int:
    if not math.isfinite(value) or value > error:
        return ERROR
    return WARN if value > warn else OK


def verdict(
    judgements: Sequence[Judgement], failed_nodes: Mapping[str, int]
) -> tuple[int, list[str], list[str]]:
    """The exit status of a chain run and its closing lines: those that hold, those that fail.

    Exit 0 only when no judgement is ERROR and every node exited 0; otherwise 1, with one
    line per failed judgement (and one for the nodes that failed) naming the cause. A WARN
    judgement holds and says so (``WARN: ...``).
    """
    held = [
        j.line if j.level == OK or j.line.startswith("loop timing") else f"WARN: {j.line}"
        for j in judgements
        if j.level != ERROR
    ]
    failed = [j.line for j in judgements if j.level == ERROR]
    if failed_nodes:
        failed.append(f"nodes exited with errors: {dict(failed_nodes)}")
    return (1 if failed else 0), held, failed
