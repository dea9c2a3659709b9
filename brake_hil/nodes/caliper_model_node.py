"""The caliper_model node's ROS side: the model stepped live at 1 kHz on ``p_i``.

What the node does, its topics and parameters: :mod:`brake_hil.nodes.caliper_model`, the
entry point (``python -m brake_hil.nodes.caliper_model``), which answers ``--help`` without
importing this.
"""

from __future__ import annotations

from collections.abc import Sequence
import struct
import threading
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.exceptions import ParameterException

from brake_hil.errors import BrakeHilError
from brake_hil.live.model_file import load_model
from brake_hil.nodes import common
from brake_hil.nodes.caliper_model import NAME
from brake_hil.nodes.settings import CaliperModelSettings
from brake_hil.runtime import (
    CatchUpRunner,
    DeadlineLoop,
    HoldMode,
    InputState,
    LoopStatistics,
    PhaseLock,
    Sample,
    Tick,
    set_process_realtime_priority,
)
from brake_hil.topics import MASTER_CYLINDER_PRESSURE, PREDICTED_OUTPUTS

FAULT_ERROR_S = 5.0
"""A non-finite input or state keeps its status at ERROR this long (s), then WARN for the run."""
FAULT_COUNTERS = ("nonfinite_inputs", "nonfinite_states", "stamps_backwards")
INPUT_LEVELS = {
    InputState.WAITING: common.STALE,
    InputState.FRESH: common.OK,
    InputState.LATE: common.WARN,
    InputState.SILENT: common.ERROR,
}


class CaliperModelNode(common.LoopNode):
    """Steps the caliper model for every received ``p_i`` sample on a 1 kHz deadline loop."""

    loop_name = "model loop"

    def __init__(self, cli_args: Sequence[str] | None = None, own_process: bool = True) -> None:
        """Build the node; its loop starts at once.

        ``cli_args`` and ``own_process`` as a container gives them to each of its nodes
        (:func:`brake_hil.nodes.container_node.launch`); in its own process the middleware's
        threads run one ``realtime_priority`` step above the loop.
        """
        # No parameter services: nothing spins this node but its loop (parameters are
        # read-only, set at start from the command line or a params file).
        super().__init__(
            NAME,
            cli_args=list(cli_args) if cli_args is not None else None,
            start_parameter_services=False,
        )
        settings = common.declare_settings(self, CaliperModelSettings)
        self.settings = settings
        if settings.paired_with_source and own_process:
            raise BrakeHilError(
                "paired_with_source needs the pressure_source in the same process "
                "(python -m brake_hil.nodes.container, or the chain's --layout paired)"
            )
        period_ns = round(settings.loop_period * 1e9)
        self.model = load_model(settings.model_file, settings.mean_pressure)
        self.statistics = LoopStatistics()
        self._runner = self._make_runner(period_ns)
        # Faults seen (count, monotonic ns of the last change): reported at once, ERROR for
        # FAULT_ERROR_S after the last one, WARN for the rest of the run.
        self._faults = dict.fromkeys(FAULT_COUNTERS, (0, 0))
        self._phase_lock = PhaseLock(period_ns) if settings.phase_lock else None
        self._builders = [
            common.RawMessageBuilder(spec, settings.frame_id) for spec in PREDICTED_OUTPUTS
        ]
        self._outputs = [
            self.create_publisher(common.message_class(spec), spec.name, common.SAMPLE_QOS)
            for spec in PREDICTED_OUTPUTS
        ]
        self._diagnostics = self.create_publisher(
            DiagnosticArray, common.DIAGNOSTICS_TOPIC, common.DIAGNOSTICS_QOS
        )
        self.corrupt = 0  # input messages too short to decode
        self.lost = 0  # gaps in the publisher's sequence numbers (middleware drops)
        self._sequence: dict[bytes, int] = {}
        # Taken by the loop itself at each tick (no executor: no second Python thread to
        # contend for the GIL at the deadline). Made once every prediction publisher has
        # matched wait_for_subscribers readers: a source that waits for its p_i subscribers
        # then starts only when the predictions of its first sample have their readers.
        self._input: common.PolledInput | None = None
        self._subscribing = threading.Lock()
        self._subscribe_when_matched()
        self._report_every = max(1, round(settings.diagnostics_period * 1e9 / period_ns))
        self._relock_every = max(1, round(1e9 / period_ns))
        self._last_report = self._last_relock = 0  # report / relock windows (slot numbers)
        self._wall_to_monotonic = time.monotonic_ns() - time.time_ns()
        self._loop = self._make_loop(period_ns)
        self.get_logger().info(f"{self.model.description} from {self.model.path}")
        if settings.realtime_priority > 0 and own_process:
            # The middleware's receive threads one step above the loop: a sample is taken in
            # as it arrives, even while the loop spins towards its deadline (a loop above them
            # would hold them off, delaying arrivals until after its tick, and the phase lock
            # would chase them).
            set_process_realtime_priority(min(99, settings.realtime_priority + 1))
        self._loop.start(held=settings.paired_with_source)

    def _make_runner(self, period_ns: int) -> CatchUpRunner:
        """The model stepped once per input sample, as the settings say.

        Raises:
            BrakeHilError: an unknown ``hold_mode``.
        """
        settings = self.settings
        try:
            hold_mode = HoldMode(settings.hold_mode)
        except ValueError as err:
            raise BrakeHilError(
                f"hold_mode must be report or hold, got {settings.hold_mode!r}"
            ) from err
        return CatchUpRunner(
            self.model.stepper(),
            period_ns=period_ns,
            late_after_ns=round(settings.input_late_ms * 1e6),
            silent_after_ns=round(settings.input_silent_ms * 1e6),
            hold_mode=hold_mode,
            statistics=self.statistics,
            restart=self.model.stepper,
        )

    def _make_loop(self, period_ns: int) -> DeadlineLoop:
        """The 1 kHz deadline loop that ticks the model (not started)."""
        settings = self.settings
        return DeadlineLoop(
            self._tick,
            period_ns=period_ns,
            spin_ns=settings.spin_margin_us * 1000,
            statistics=self.statistics,
            realtime_priority=settings.realtime_priority,
            on_error=self._on_loop_error,
            idle=self._take_input,  # samples are taken in while spinning to the deadline
            while_held=self._subscribe_when_matched,  # paired: subscribed before the source plays
            name="caliper-model-loop",
        )

    # -- paired with the source (one container) -----------------------------------------

    def follow(self, deadline_ns: int, wake_ns: int) -> None:
        """One tick on the caller's thread: the paired source, right after its publishes.

        ``deadline_ns``, ``wake_ns``: the source's tick (monotonic); the model's period error
        is then the source's. Fast DDS delivers inside the process before ``publish``
        returns, so the tick takes the sample just published.
        """
        self._loop.drive(deadline_ns, wake_ns)

    def unpair(self) -> None:
        """The paired source stopped replaying: the loop's own thread ticks from now on."""
        self._loop.release()

    # -- the loop (its own thread) -----------------------------------------------------

    def _subscribe_when_matched(self) -> bool:
        """Subscribe to ``p_i`` once the prediction publishers have their readers.

        Called by the loop's thread (while spinning, or while held for a paired source) and by
        the tick, which may be on the paired source's thread: once, under a lock.
        """
        with self._subscribing:
            if self._input is not None:
                return True
            wanted = self.settings.wait_for_subscribers
            if all(publisher.get_subscription_count() >= wanted for publisher in self._outputs):
                self._input = common.PolledInput(self, MASTER_CYLINDER_PRESSURE)
                return True
            return False

    def _take_input(self) -> None:
        """Queue every input sample the middleware holds, with its receive time."""
        if self._input is None and not self._subscribe_when_matched():
            return
        assert self._input is not None
        offset = self._wall_to_monotonic
        lock = self._phase_lock
        read = self._input.read
        for data, info in self._input.take_all():
            received = info["received_timestamp"]
            arrival = received + offset if received else time.monotonic_ns()
            self._check_sequence(info)
            try:
                stamp, value = read(data)
            except (struct.error, IndexError):
                self.corrupt += 1
                continue
            self._runner.push(Sample(stamp, value, arrival))
            if lock is not None:
                lock.observe(arrival)

    def _check_sequence(self, info: Any) -> None:
        number = info.get("publication_sequence_number")
        if number is None:
            return
        gid = bytes(info["publisher_gid"]["data"])
        previous = self._sequence.get(gid)
        if previous is not None and number > previous + 1:
            self.lost += number - previous - 1
        self._sequence[gid] = number

    def _tick(self, tick: Tick) -> None:
        self._take_input()
        result = self._runner.tick(tick.wake_ns)
        if result.predictions:
            self._publish(result.predictions)
            add, wake = self.statistics.add, tick.wake_ns
            for prediction in result.predictions:
                if not prediction.held:
                    add("input_wait", wake - prediction.arrival_ns)
        slot = tick.slot
        new_fault = self._note_faults(tick.wake_ns)
        if new_fault or result.state_changed or slot // self._report_every != self._last_report:
            self._last_report = slot // self._report_every
            self._report()
        relock = slot // self._relock_every != self._last_relock and not self._loop.held
        if self._phase_lock is not None and relock:
            self._last_relock = slot // self._relock_every
            phase = self._phase_lock.propose(self._loop.phase_ns)
            if phase is not None:
                self._loop.request_phase(phase)

    def _note_faults(self, now_ns: int) -> bool:
        """Record fault counters that moved since the last tick; True when one did."""
        counters = self.statistics.counters
        moved = False
        for name, (count, _) in self._faults.items():
            value = getattr(counters, name)
            if value != count:
                self._faults[name] = (value, now_ns)
                moved = True
        return moved

    def _fault_level(self, name: str, now_ns: int) -> int:
        """OK when ``name`` never counted, ERROR within FAULT_ERROR_S of its last, else WARN."""
        count, since = self._faults[name]
        if count == 0:
            return common.OK
        return common.ERROR if now_ns - since < FAULT_ERROR_S * 1e9 else common.WARN

    def _publish(self, predictions: Sequence[Any]) -> None:
        builders, publishers = self._builders, self._outputs
        for prediction in predictions:
            stamp = prediction.stamp_ns
            for index in range(3):
                publishers[index].publish(builders[index](stamp, prediction[index + 1]))
        published, wall = time.monotonic_ns(), time.time_ns()
        add = self.statistics.add
        for prediction in predictions:
            if not prediction.held:
                add("latency", published - prediction.arrival_ns)
                add("stamp_age", wall - prediction.stamp_ns)

    # -- reporting -----------------------------------------------------------------------

    def _report(self) -> None:
        if not self.context.ok():
            return
        self._wall_to_monotonic = time.monotonic_ns() - time.time_ns()  # follows clock steps
        self._diagnostics.publish(common.diagnostic_array(self, self.statuses()))

    def statuses(self) -> list[Any]:
        """The node's diagnostics now: loop, input, model."""
        window = self.statistics.take_window()
        now = time.monotonic_ns()
        self._note_faults(now)
        return [self._loop_status(window), self._input_status(now), self._model_status(now)]

    def _loop_status(self, window: Any) -> Any:
        """``caliper_model: loop``: timing over the report window, tick counters."""
        counters = self.statistics.counters
        level, message = common.OK, "1 kHz loop on time"
        if self._loop.error is not None:
            level, message = common.ERROR, f"loop stopped: {self._loop.error}"
        elif window["period_error"].max_us >= 1000.0:
            level, message = common.WARN, "ticks over 1 ms late in this window"
        values: list[tuple[str, object]] = [
            *common.timing_values(window),
            ("ticks", counters.ticks),
            ("late_ticks", counters.late_ticks),
            ("overruns", counters.overruns),
            ("ticks_skipped", counters.ticks_skipped),
            ("caught_up_ticks", counters.caught_up_ticks),
            ("caught_up_samples", counters.caught_up_samples),
            ("max_samples_per_tick", counters.max_per_tick),
            ("phase_us", (self._loop.phase_ns or 0) / 1000.0),
            ("phase_shifts", counters.phase_shifts),
            ("timer_slack_1ns", self._loop.timer_slack),
            ("sched_fifo", self._loop.realtime),
            ("stepped_by", "pressure_source's thread" if self._loop.held else "own loop"),
            ("driven_ticks", self._loop.driven_ticks),
        ]
        return common.diagnostic_status(f"{NAME}: loop", level, message, values)

    def _input_status(self, now: int) -> Any:
        """``caliper_model: input``: its state, silence, held and faulty samples."""
        counters = self.statistics.counters
        state = self._runner.state
        silence = self._runner.silence_ns(now)
        level = INPUT_LEVELS[state]
        message = f"input {state.value}"
        if silence is not None and state is not InputState.FRESH:
            message += f": no p_i for {silence / 1e6:.1f} ms"
        holding = self._runner.hold_mode is HoldMode.HOLD and state is InputState.SILENT
        if holding and counters.held:
            level, message = common.WARN, message + f"; holding last input ({counters.held} held)"
        if counters.nonfinite_inputs:
            level = max(level, self._fault_level("nonfinite_inputs", now))
            stamp = self._runner.last_nonfinite_stamp_ns or 0
            message += (
                f"; non-finite p_i at stamp {stamp / 1e9:.3f} s not stepped, input held "
                f"({counters.nonfinite_inputs} so far)"
            )
        if counters.stamps_backwards:
            level = max(level, common.WARN)
            message += (
                f"; {counters.stamps_backwards} samples stamped at or before their predecessor "
                "dropped (never two predictions with one stamp)"
            )
        values: list[tuple[str, object]] = [
            ("state", state.value),
            ("silence_ms", -1.0 if silence is None else silence / 1e6),
            ("samples", counters.samples),
            ("predictions", counters.predictions),
            ("pending", self._runner.pending),
            ("corrupt", self.corrupt),
            ("lost_in_transport", self.lost),
            ("missing_samples", counters.missing_samples),
            ("stamps_backwards", counters.stamps_backwards),
            ("nonfinite_inputs", counters.nonfinite_inputs),
            ("last_nonfinite_stamp_ns", self._runner.last_nonfinite_stamp_ns or 0),
            ("held", counters.held),
            ("superseded", counters.superseded),
            ("hold_mode", self._runner.hold_mode.value),
        ]
        return common.diagnostic_status(f"{NAME}: input", level, message, values)

    def _model_status(self, now: int) -> Any:
        """``caliper_model: model``: the model, and its non-finite states."""
        counters = self.statistics.counters
        values = [
            ("model_file", str(self.model.path)),
            ("mean_pressure_pa", self.model.mean_pressure),
            ("nonfinite_states", counters.nonfinite_states),
            ("state_resets", counters.state_resets),
        ]
        level, message = common.OK, self.model.description
        if counters.nonfinite_states:
            level = self._fault_level("nonfinite_states", now)
            message = (
                f"non-finite model state {counters.nonfinite_states} times (not published); "
                f"reset to the equilibrium at the next good input {counters.state_resets} times"
            )
        return common.diagnostic_status(f"{NAME}: model", level, message, values)

    def close(self) -> None:
        """Stop the loop, step and publish what is still queued, report, write statistics."""
        self._loop.stop()
        if self.context.ok() and self._loop.error is None:
            self._take_input()
            self._publish(self._runner.tick(time.monotonic_ns()).predictions)
        self._report()
        if self.context.ok() and not common.wait_for_acks(self._outputs):
            self.get_logger().warning(
                f"subscribers had not acknowledged every prediction after {common.ACK_WAIT_S:g} s"
            )
        summary = {**self.statistics.summary(), "driven_ticks": self._loop.driven_ticks}
        counters = self.statistics.counters
        self.get_logger().info(
            f"{counters.samples} samples in, {counters.predictions} predictions out, "
            f"{counters.overruns} overruns, {counters.late_ticks} ticks over 1 ms late"
        )
        common.write_summary(self.settings.statistics_file, summary)


def main(args: list[str] | None = None) -> int:
    """The node's process (its help answered by the entry point): run until SIGINT/SIGTERM."""
    return common.run_node(
        NAME, args, CaliperModelNode, (BrakeHilError, ParameterException), common.run_until_stopped
    )
