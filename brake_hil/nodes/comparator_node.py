"""The comparator node's ROS side: the live comparison of predictions and measurements.

What the node does, its topics and parameters: :mod:`brake_hil.nodes.comparator`, the
entry point (``python -m brake_hil.nodes.comparator``), which answers ``--help`` without
importing this.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
import math
import struct
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
import numpy as np
from rclpy.exceptions import ParameterException

from brake_hil.analysis.stamp_scoring import (
    METRIC_KEYS,
    PairedWindow,
    StampPairer,
    WindowResult,
    evaluate_cycle,
    peak_stamp_ns,
)
from brake_hil.errors import BrakeHilError
from brake_hil.nodes import common
from brake_hil.nodes.comparator import NAME
from brake_hil.nodes.settings import ComparatorSettings
from brake_hil.runtime import DeadlineLoop, Tick
from brake_hil.topics import MEASURED_OUTPUTS, OUTPUT_CHANNELS, PREDICTED_OUTPUTS

CHANNEL_LAG_NS = 10_000_000_000
"""A channel whose pairs lag the others' by more than this (ns) no longer holds their scoring
back (pairs are kept 30 s)."""
NO_MATCH_S = 3.0
"""ERROR once both sides of a channel arrive but nothing has paired for this long (s)."""


@dataclass
class MatchWatch:
    """Watches one channel's pairing: do predictions still match measurement stamps?"""

    received: tuple[int, int] = (0, 0)  # predicted, measured samples received so far
    paired: int = 0
    last_arrival_ns: tuple[int | None, int | None] = (None, None)  # monotonic, per side
    arriving_since_ns: int | None = None  # monotonic: both sides arriving since
    last_pair_ns: int | None = None  # monotonic: a new pair last seen

    def update(self, pairer: StampPairer, now_ns: int) -> float | None:
        """Seconds without a new pair while both sides arrive; None when pairing is fine.

        A side "arrives" while it has grown within ``NO_MATCH_S`` (samples come in bursts on
        a busy machine: one quiet evaluation does not restart the clock).
        """
        pending_predicted, pending_measured = pairer.pending
        received = (
            pairer.paired + pairer.unpaired_predicted + pending_predicted,
            pairer.paired + pairer.unpaired_measured + pending_measured,
        )
        self.last_arrival_ns = tuple(  # type: ignore[assignment]
            now_ns if new > old else last
            for new, old, last in zip(received, self.received, self.last_arrival_ns)
        )
        self.received = received
        if pairer.paired > self.paired:
            self.paired, self.last_pair_ns = pairer.paired, now_ns
        window_ns = NO_MATCH_S * 1e9
        both = all(t is not None and now_ns - t < window_ns for t in self.last_arrival_ns)
        if not both:
            self.arriving_since_ns = None
            return None
        if self.arriving_since_ns is None:
            self.arriving_since_ns = now_ns
        since = max(self.arriving_since_ns, self.last_pair_ns or self.arriving_since_ns)
        silent_s = (now_ns - since) / 1e9
        return silent_s if silent_s >= NO_MATCH_S else None


class ComparatorNode(common.LoopNode):
    """Pairs predictions with measurements by stamp and scores them once a cycle."""

    loop_name = "comparator loop"

    def __init__(self, cli_args: Sequence[str] | None = None) -> None:
        """Build the node (``cli_args``: its own ROS arguments); its loop starts at once."""
        # One thread does all the work (no executor, so no parameter services): it takes the
        # six 1 kHz topics in batches every 50 ms, without a Python callback per message.
        super().__init__(
            NAME,
            cli_args=list(cli_args) if cli_args is not None else None,
            start_parameter_services=False,
        )
        self.settings = settings = common.declare_settings(self, ComparatorSettings)
        excitation_hz, sample_period = settings.excitation_hz, settings.sample_period
        self._window_cycles = settings.window_cycles
        self.thresholds = settings.thresholds
        if not excitation_hz > 0.0 or self._window_cycles < 1 or not sample_period > 0.0:
            raise BrakeHilError("excitation_hz, window_cycles and sample_period must be > 0")
        self.period_s = 1.0 / excitation_hz
        self._sample_period_ns = round(sample_period * 1e9)
        span = round((self._window_cycles + 2) * self.period_s / sample_period)
        self.pairers = {
            # unpaired samples wait 30 s of stamps, pairs are kept 30 s: a model that falls
            # behind, or a comparator that takes seconds of samples at once, loses no cycle
            channel: StampPairer(capacity=max(span, 30_000))
            for channel in OUTPUT_CHANNELS
        }
        self.cycles: dict[str, list[dict[str, float]]] = {c: [] for c in OUTPUT_CHANNELS}
        self._watches = {channel: MatchWatch() for channel in OUTPUT_CHANNELS}
        self._no_match: dict[str, float | None] = dict.fromkeys(OUTPUT_CHANNELS)
        self.no_match_reports = 0  # evaluations at which a channel had no match
        self._period_ns = round(self.period_s * 1e9)
        self._span_ns = (self._window_cycles + 2) * self._period_ns  # a window and its guards
        self._next_cycle_end: int | None = None  # stamp (ns) ending the next cycle to score
        self._aligned = False  # cycles start at a peak of p_b (after the first steady window)
        self.evaluations = 0  # cycles evaluated
        self.corrupt = 0  # messages too short to decode
        self.evaluation_errors = 0  # windows whose scoring raised
        self._inputs: list[tuple[common.PolledInput, Callable[[int, float], None]]] = []
        topics = zip(OUTPUT_CHANNELS, MEASURED_OUTPUTS, PREDICTED_OUTPUTS)
        for channel, measured, predicted in topics:
            pairer = self.pairers[channel]
            self._inputs.append((common.PolledInput(self, measured), pairer.add_measured))
            self._inputs.append((common.PolledInput(self, predicted), pairer.add_predicted))
        self._outputs = [
            self.create_publisher(DiagnosticArray, topic, common.DIAGNOSTICS_QOS)
            for topic in (common.COMPARISON_TOPIC, common.DIAGNOSTICS_TOPIC)
        ]
        self._evaluate_every = 4  # takes (of 50 ms) per evaluation
        self._loop = DeadlineLoop(
            self._tick,
            period_ns=self._period_ns // self._evaluate_every,
            spin_ns=0,
            on_error=self._on_loop_error,
            name="comparator-loop",
        )
        self._loop.start()

    def _tick(self, tick: Tick) -> None:
        self._take()
        if tick.slot % self._evaluate_every == 0 or tick.skipped:
            self._evaluate()

    def _take(self) -> None:
        for polled, add in self._inputs:
            read = polled.read
            for data, _ in polled.take_all():
                try:
                    stamp, value = read(data)
                except (struct.error, IndexError):
                    self.corrupt += 1
                    continue
                add(stamp, value)

    def _evaluate(self, final: bool = False) -> None:
        """Score every cycle whose window (and guard period) the paired samples now cover.

        ``final``: the run is over, score what any channel covers.
        """
        since = None if self._next_cycle_end is None else self._next_cycle_end - self._span_ns
        windows = {channel: pairer.window(since) for channel, pairer in self.pairers.items()}
        now = time.monotonic_ns()
        self._no_match = {
            channel: self._watches[channel].update(pairer, now)
            for channel, pairer in self.pairers.items()
        }
        no_match = any(value is not None for value in self._no_match.values())
        self.no_match_reports += no_match
        newest = [int(w.stamps_ns[-1]) for w in windows.values() if w.stamps_ns.size]
        if not newest:
            self._publish(self._statuses(windows, None)[0])
            return
        if self._next_cycle_end is None:
            first = min(int(w.stamps_ns[0]) for w in windows.values() if w.stamps_ns.size)
            self._next_cycle_end = first + (self._window_cycles + 1) * self._period_ns
        published = False
        while self._next_cycle_end + self._period_ns <= self._covered_until(newest, final):
            statuses, steady = self._statuses(windows, self._next_cycle_end)
            self._publish(statuses)
            self._next_cycle_end += self._period_ns
            published = True
            if steady and not self._aligned:
                self._align(windows[OUTPUT_CHANNELS[0]])
        if not published and (self.evaluations == 0 or no_match):
            self._publish(self._statuses(windows, None)[0])

    def _covered_until(self, newest: list[int], final: bool) -> int:
        """The newest stamp (ns) every channel's pairs reach: a cycle is scored once all have it.

        Channels pair at their own pace on a busy machine (a channel scored before its pairs
        arrive would miss that cycle for good); a channel more than ``CHANNEL_LAG_NS`` behind
        the others (one that stopped pairing) no longer holds them back, nor any at the end.
        """
        if final or len(newest) < len(self.pairers) or max(newest) - min(newest) > CHANNEL_LAG_NS:
            return max(newest)
        return min(newest)

    def _align(self, window: PairedWindow) -> None:
        """Once: move the cycle grid so cycles start at a peak of the measured bore pressure.

        The grid moves by under half a period; starting at a peak puts both mean crossings
        well inside each cycle.
        """
        assert self._next_cycle_end is not None
        span = (self._window_cycles + 2) * self._period_ns
        keep = window.stamps_ns > window.stamps_ns[-1] - span
        peak = peak_stamp_ns(PairedWindow(*(part[keep] for part in window)), self.period_s)
        half = self._period_ns // 2
        cycles = -((peak - (self._next_cycle_end - half)) // self._period_ns)  # ceil
        self._next_cycle_end = peak + cycles * self._period_ns
        self._aligned = True

    def _statuses(self, windows: dict[str, Any], cycle_end: int | None) -> tuple[list[Any], bool]:
        """The array for the cycle ending at ``cycle_end``; and whether p_b was steady."""
        statuses = []
        worst = common.OK
        steady = False
        for channel, window in windows.items():
            if cycle_end is None:
                result = WindowResult(False, None, None, "filling the window")
            else:
                try:
                    result = evaluate_cycle(
                        window,
                        cycle_end,
                        self.period_s,
                        self._window_cycles,
                        self._sample_period_ns,
                    )
                except ValueError as err:  # a numerical edge case: report it, keep running
                    self.evaluation_errors += 1
                    result = WindowResult(False, None, None, f"evaluation failed: {err}")
                if result.steady and result.cycle is not None:
                    self.cycles[channel].append(result.cycle)
                steady = steady or (channel == OUTPUT_CHANNELS[0] and result.steady)
            status, level = self._status(channel, self.pairers[channel], result, cycle_end)
            statuses.append(status)
            if level != common.STALE:
                worst = max(worst, level)
        self.evaluations += cycle_end is not None
        scored = min(len(cycles) for cycles in self.cycles.values())
        message = f"{scored} steady cycles scored"
        unmatched = [channel for channel, value in self._no_match.items() if value is not None]
        if unmatched:
            worst = common.ERROR
            message = f"no prediction matches a measurement stamp ({', '.join(unmatched)}); "
            message += f"{scored} steady cycles scored"
        statuses.append(
            common.diagnostic_status(
                f"{NAME}: summary",
                worst,
                message,
                {
                    "no_match_reports": self.no_match_reports,
                    "cycles_evaluated": self.evaluations,
                    "cycles_scored": scored,
                    "corrupt_messages": self.corrupt,
                    "evaluation_errors": self.evaluation_errors,
                },
            )
        )
        return statuses, steady

    def _publish(self, statuses: list[Any]) -> None:
        array = common.diagnostic_array(self, statuses)
        for publisher in self._outputs:
            publisher.publish(array)

    def _status(
        self, channel: str, pairer: StampPairer, result: WindowResult, cycle_end: int | None
    ) -> tuple[Any, int]:
        pending_predicted, pending_measured = pairer.pending
        values: list[tuple[str, object]] = [
            ("paired", pairer.paired),
            ("unpaired_predicted", pairer.unpaired_predicted),
            ("unpaired_measured", pairer.unpaired_measured),
            *((f"unpaired_{why}", n) for why, n in pairer.unpaired_reasons.items()),
            ("pending_predicted", pending_predicted),
            ("pending_measured", pending_measured),
            ("cycle_end_stamp_ns", -1 if cycle_end is None else cycle_end),
            ("window_cycles", self._window_cycles),
        ]
        if result.window is None:
            level = common.STALE if pairer.paired == 0 else common.OK
            message = result.reason
        else:
            level = self.thresholds.level(result.window)
            window = result.window
            message = (
                f"ptp {window['ptp_ratio_pct']:.1f} %, tau/T {window['tau_over_T_pct']:.2f} %, "
                f"NRMSE {window['nrmse']:.3f} over {self._window_cycles} cycles"
            )
            values += [(f"window_{key}", window[key]) for key in METRIC_KEYS]
            if result.cycle is not None:
                values += [(f"cycle_{key}", result.cycle[key]) for key in METRIC_KEYS]
                cycle_level = self.thresholds.level(result.cycle)
                values.append(("cycle_level", common.LEVEL_NAMES[cycle_level]))
            else:
                values.append(("cycle_note", result.reason))
        no_match_s = self._no_match[channel]
        if no_match_s is not None:
            level = common.ERROR
            message = (
                f"no prediction matches a measurement stamp for {no_match_s:.1f} s "
                f"({pairer.paired} paired in all)"
            )
        return common.diagnostic_status(f"{NAME}: {channel}", level, message, values), level

    def summary(self) -> dict[str, Any]:
        """The run so far: per channel, the means of every steady cycle scored."""
        channels: dict[str, Any] = {}
        for channel, cycles in self.cycles.items():
            entry: dict[str, Any] = {"cycles": len(cycles)}
            if cycles:
                for key in METRIC_KEYS:
                    entry[key] = float(np.mean([cycle[key] for cycle in cycles]))
                entry["level"] = common.LEVEL_NAMES[self.thresholds.level(entry)]
            pairer = self.pairers[channel]
            entry["paired"] = pairer.paired
            reasons = pairer.unpaired_now()  # those still waiting count as unpaired now
            entry["unpaired"] = sum(reasons.values())
            entry["unpaired_reasons"] = reasons
            channels[channel] = entry
        return {"window_cycles": self._window_cycles, "metrics": channels}

    def close(self) -> None:
        """Stop the loop, score what has arrived, log the summary and write it."""
        self._loop.stop()
        if self.context.ok() and self._loop.error is None:
            self._take()
            self._evaluate(final=True)
        summary = self.summary()
        for channel, entry in summary["metrics"].items():
            if entry["cycles"]:
                text = ", ".join(
                    f"{key} {entry[key]:.4g}" for key in METRIC_KEYS if math.isfinite(entry[key])
                )
                self.get_logger().info(f"{channel}: {text} over {entry['cycles']} cycles")
        common.write_summary(self.settings.summary_file, summary)


def main(args: list[str] | None = None) -> int:
    """The node's process (its help answered by the entry point): run until SIGINT/SIGTERM."""
    return common.run_node(
        NAME, args, ComparatorNode, (BrakeHilError, ParameterException), common.run_until_stopped
    )
