"""The pressure_source node's ROS side: the rig's ``p_i`` and measurements on the graph.

What the node does, its topics and parameters: :mod:`brake_hil.nodes.pressure_source`, the
entry point (``python -m brake_hil.nodes.pressure_source``), which answers ``--help`` without
importing this. The replay (:class:`~brake_hil.io.replay.Replay`), the CAN acquisition
(:class:`~brake_hil.io.can_acquisition.CanAcquisition`) and the CAN log replay
(:class:`~brake_hil.io.can_log.CanLogReplay`) are ROS-free; this node gives them publishers, a
worker thread, a wait for subscribers and diagnostics.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
import threading
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.exceptions import ParameterException
from rclpy.node import Node

from brake_hil.errors import BrakeHilError
from brake_hil.io.can_acquisition import CanAcquisition
from brake_hil.io.can_log import CanLogReplay
from brake_hil.io.replay import Replay
from brake_hil.nodes import common
from brake_hil.nodes.pressure_source import NAME
from brake_hil.nodes.settings import PressureSourceSettings
from brake_hil.runtime import (
    LoopStatistics,
    StampMode,
    set_process_realtime_priority,
    set_realtime_priority,
    set_timer_slack,
)
from brake_hil.topics import QUANTITY_TOPICS, TopicSpec

__all__ = ["PressureSourceNode", "main"]


class PressureSourceNode(Node):
    """Replays a recording, or acquires from the rig's CAN DAQ, onto the contract topics."""

    def __init__(self, cli_args: Sequence[str] | None = None, own_process: bool = True) -> None:
        """Build the node; its worker thread starts at once.

        ``cli_args`` and ``own_process`` as a container gives them to each of its nodes
        (:func:`brake_hil.nodes.container_node.launch`); in its own process the worker runs
        one ``realtime_priority`` step above the process's other threads.
        """
        super().__init__(NAME, cli_args=list(cli_args) if cli_args is not None else None)
        self.settings = settings = common.declare_settings(self, PressureSourceSettings)
        self.mode = settings.mode
        if settings.rate <= 0.0:
            raise BrakeHilError(f"rate must be positive, got {settings.rate}")
        self.state = "starting"
        self._stop = threading.Event()
        self.exit_requested = threading.Event()  # set at the end of a replay with exit_at_end
        self._diagnostics = self.create_publisher(
            DiagnosticArray, common.DIAGNOSTICS_TOPIC, common.DIAGNOSTICS_QOS
        )
        self._outputs: dict[TopicSpec, Any] = {}
        self._builders: dict[TopicSpec, common.RawMessageBuilder] = {}
        self._replay: Replay | None = None
        self._acquisition: CanAcquisition | None = None
        self._can_log: CanLogReplay | None = None
        # Paired nodes (one container): ticked after each replayed sample, told at its end.
        self._followers: list[Callable[[int, int], None]] = []
        self._on_replay_end: list[Callable[[], None]] = []
        self._pair_lock = threading.Lock()
        self._replay_over = False
        self._realtime = False  # the worker obtained SCHED_FIFO
        if self.mode == "replay":
            self._prepare_replay()
            target: Callable[[], None] = self._play
        elif self.mode == "can":
            self._prepare_can()
            target = self._acquire
        elif self.mode == "can_log":
            self._prepare_can_log()
            target = self._play_can_log
        else:
            raise BrakeHilError(f"mode must be replay, can or can_log, got {self.mode!r}")
        self.statistics = self._replay.statistics if self._replay else LoopStatistics()
        self.create_timer(settings.diagnostics_period, self._report)
        if settings.realtime_priority > 0 and own_process:
            # the worker one step above the node's other threads
            set_process_realtime_priority(max(1, settings.realtime_priority - 1))
        self._thread = threading.Thread(target=self._guarded(target), name=NAME, daemon=True)
        self._thread.start()

    @property
    def published(self) -> int:
        """Samples (``p_i`` messages) published so far."""
        worker = self._replay or self._acquisition
        return worker.published if worker is not None else 0

    @property
    def passes(self) -> int:
        """Replay passes played to their end."""
        return self._replay.passes if self._replay is not None else 0

    def _advertise(self, specs: list[TopicSpec]) -> None:
        for spec in specs:
            self._outputs[spec] = self.create_publisher(
                common.message_class(spec), spec.name, common.SAMPLE_QOS
            )
            self._builders[spec] = common.RawMessageBuilder(spec, self.settings.frame_id)

    def _output(self, spec: TopicSpec) -> tuple[Callable[[Any], object], Any]:
        """Where the samples of ``spec`` go: its publisher's ``publish`` and message builder."""
        return self._outputs[spec].publish, self._builders[spec]

    def _guarded(self, target: Callable[[], None]) -> Callable[[], None]:
        def run() -> None:
            try:
                target()
            except Exception as err:  # noqa: BLE001 - reported; the node stays up
                if self.context.ok():
                    self.state = f"failed: {err}"
                    self.get_logger().error(f"{self.mode} stopped: {type(err).__name__}: {err}")
                    self._report()

        return run

    def _start_worker(self) -> None:
        """On the worker thread: its timer slack and priority, then the wait for subscribers."""
        set_timer_slack(1)
        self._realtime = set_realtime_priority(self.settings.realtime_priority)
        if self.mode != "can" or self._waits():
            self._wait_for_graph()

    # -- replay ------------------------------------------------------------------------

    def _prepare_replay(self) -> None:
        settings = self.settings
        self._replay = replay = Replay(
            settings.recording,
            settings.stamp_mode,
            settings.publish_measured,
            settings.start_offset,
            settings.duration,
        )
        self._advertise(replay.specs)
        self.get_logger().info(
            f"replaying {settings.recording}: {replay.samples} samples of "
            f"{', '.join(s.name for s in replay.specs)} "
            f"at rate {settings.rate:g}{', looped' if settings.loop else ''}"
        )

    def _wait_for_graph(self) -> None:
        """Wait (bounded) for the subscribers the parameters ask for.

        On the source's own topics the count is of subscriptions matched by its publisher
        (what the middleware will deliver to); on other topics, of subscriptions on the graph.
        Besides the counts asked for, every subscription the graph shows on an own topic must
        be matched. Every 2 s of waiting the log says what is still missing.
        """
        own = {pub.topic_name: pub for pub in self._outputs.values()}
        topics = dict.fromkeys(own, self.settings.wait_for_subscribers)
        for entry in self.settings.wait_for_topics:
            if not entry.strip():
                continue
            name, _, wanted = entry.strip().partition(":")
            topics[name] = max(topics.get(name, 0), int(wanted or 1))

        def count(name: str) -> int:
            publisher = own.get(name)
            if publisher is not None:
                return int(publisher.get_subscription_count())
            return int(self.count_subscribers(name))

        def unmatched() -> list[str]:
            # Subscriptions on the graph that the publisher has not matched yet.
            return [
                name
                for name, publisher in own.items()
                if publisher.get_subscription_count() < self.count_subscribers(name)
            ]

        started = time.monotonic()
        deadline = started + self.settings.wait_timeout
        said = started
        while not self._stop.is_set():
            short = {n: (count(n), c) for n, c in topics.items() if count(n) < c}
            pending = unmatched()
            if not short and not pending:
                self.get_logger().info(
                    f"subscribers matched after {time.monotonic() - started:.1f} s: starting"
                )
                return
            waiting = [f"{n} ({have} of {want})" for n, (have, want) in sorted(short.items())]
            waiting += [f"{n} (a subscriber not matched yet)" for n in pending if n not in short]
            if time.monotonic() > deadline:
                self.get_logger().warning(
                    f"starting after {self.settings.wait_timeout:g} s without all subscribers: "
                    + ", ".join(waiting)
                )
                return
            if time.monotonic() - said >= 2.0:
                said = time.monotonic()
                self.get_logger().info(
                    f"waiting for subscribers ({said - started:.0f} s of at most "
                    f"{self.settings.wait_timeout:g} s): " + ", ".join(waiting)
                )
            self.state = "waiting for subscribers"
            time.sleep(0.02)

    def pair(self, follow: Callable[[int, int], None], on_end: Callable[[], None]) -> None:
        """Run ``follow(deadline_ns, wake_ns)`` on the replay thread after each sample.

        For a node in the same process (the caliper model, ``paired_with_source``): one thread
        for both 1 kHz loops. ``on_end()`` is called once when the replay stops (at its end, on
        a stop or a failure; at once if it has already stopped).

        Raises:
            BrakeHilError: the source is not replaying (a CAN DAQ's frames come when they come).
        """
        if self.mode != "replay":
            raise BrakeHilError(f"a pressure_source in mode {self.mode} cannot be paired")
        with self._pair_lock:
            over = self._replay_over
            if not over:
                self._followers.append(follow)
                self._on_replay_end.append(on_end)
        if over:
            on_end()

    def _play(self) -> None:
        replay, settings = self._replay, self.settings
        assert replay is not None
        try:
            self._start_worker()
            self._stop.wait(settings.start_delay)
            self.state = "playing"
            outputs = [self._output(spec) for spec in replay.specs]
            # A spin at normal priority buys no timing and takes the CPU the chain needs.
            spin_us = settings.spin_margin_us if self._realtime else 0
            replay.play(
                outputs,
                self._stop,
                settings.rate,
                settings.loop,
                spin_us,
                self._followers,  # the list itself: a node paired later is seen
            )
        finally:
            with self._pair_lock:
                self._replay_over = True
                ends, self._on_replay_end = self._on_replay_end, []
            for end in ends:
                end()
        if not self._stop.is_set():
            self.state = "finished"
            self.get_logger().info(f"replay finished: {self.published} samples published")
            self._report()
            if settings.exit_at_end:
                self.exit_requested.set()

    # -- CAN ---------------------------------------------------------------------------

    def _prepare_can(self) -> None:
        from brake_hil.io.can_daq import CanDaq

        settings = self.settings
        options = {"sleep_after_open": settings.can_sleep_after_open}
        daq = CanDaq(
            settings.can_interface,
            settings.can_channel,
            settings.can_bitrate,
            dbc_path=settings.dbc_file,
            stale_after_s=settings.stale_after_ms / 1e3,
            bus_kwargs=options if settings.can_interface == "slcan" else None,
        )
        if not self._waits():  # else opened after the wait (_acquire)
            daq.open()  # a missing driver fails here; a missing adapter is retried
        self._acquisition = acquisition = CanAcquisition(
            daq, settings.publish_measured, self._report, settings.realtime_priority
        )
        self._advertise([QUANTITY_TOPICS[q] for q in acquisition.quantities])
        self.get_logger().info(
            f"acquiring {', '.join(acquisition.quantities)} from CAN {settings.can_interface} "
            f"{settings.can_channel} at {settings.can_bitrate} bit/s"
        )

    def _waits(self) -> bool:
        """A wait for subscribers was asked for (``wait_for_subscribers``, ``wait_for_topics``)."""
        return self.settings.wait_for_subscribers > 0 or any(
            entry.strip() for entry in self.settings.wait_for_topics
        )

    def _acquire(self) -> None:
        acquisition = self._acquisition
        assert acquisition is not None
        self._start_worker()  # then open: the DAQ's port opening may start the sender
        outputs = {q: self._output(QUANTITY_TOPICS[q]) for q in acquisition.quantities}
        self.state = "acquiring"
        acquisition.run(outputs, self._stop)

    # -- CAN log -----------------------------------------------------------------------

    def _prepare_can_log(self) -> None:
        settings = self.settings
        if not settings.can_log:
            raise BrakeHilError("can_log: no CAN log given (parameter can_log)")
        self._can_log = log = CanLogReplay(
            settings.can_log,
            settings.dbc_file,
            settings.publish_measured,
            self._report,
            settings.rate,
            StampMode(settings.stamp_mode),
            settings.stale_after_ms / 1e3,
        )
        self._acquisition = log.acquisition
        self._advertise([QUANTITY_TOPICS[q] for q in log.quantities])
        self.get_logger().info(
            f"replaying the CAN log {settings.can_log}: {len(log.frames)} frames over "
            f"{log.duration_s:.3f} s, {', '.join(log.quantities)} at rate {settings.rate:g}"
        )

    def _play_can_log(self) -> None:
        log = self._can_log
        assert log is not None
        self._start_worker()
        self._stop.wait(self.settings.start_delay)
        if self._stop.is_set():
            return
        self.state = "playing"
        outputs = {q: self._output(QUANTITY_TOPICS[q]) for q in log.quantities}
        if log.run(outputs, self._stop):
            self.state = "finished"
            self.get_logger().info(f"CAN log finished: {self._log_counts()}")
            self._report()
            if self.settings.exit_at_end:
                self.exit_requested.set()

    def _log_counts(self) -> str:
        health = self.daq_health()
        return (
            f"{self.published} samples published; {health['lost_samples']} lost in the log, "
            f"{health['stale_counters']} frames with a frozen counter, "
            f"{health['crc_errors'] + health['dlc_errors'] + health['unknown_ids']} bad frames"
        )

    def daq_health(self) -> dict[str, Any]:
        """The DAQ's counters (CAN and CAN log modes)."""
        assert self._acquisition is not None
        return self._acquisition.summary()

    def _can_log_status(self, failed: bool) -> Any:
        log = self._can_log
        assert log is not None
        level, message, values = log.acquisition.status()
        values.update(
            state=self.state,
            can_log=str(log.path),
            frames=len(log.frames),
            replayed=log.replayed,
            rate=self.settings.rate,
        )
        if self.state == "finished":  # the log's end: no longer live, judged by its counts
            health = self.daq_health()
            faults = sum(
                health[key]
                for key in (
                    "lost_samples",
                    "stale_counters",
                    "crc_errors",
                    "dlc_errors",
                    "unknown_ids",
                    "bus_errors",
                )
            )
            level = common.WARN if faults else common.OK
            message = f"CAN log finished: {self._log_counts()}"
        elif self.state != "playing":
            level, message = common.STALE, f"CAN log {self.state}"
        if failed:
            level, message = common.ERROR, self.state
        return common.diagnostic_status(f"{NAME}: can_log", level, message, values)

    # -- reporting -----------------------------------------------------------------------

    def _report(self) -> None:
        if self.context.ok():
            self._diagnostics.publish(common.diagnostic_array(self, self.statuses()))

    def statuses(self) -> list[Any]:
        """The node's diagnostics now."""
        failed = self.state.startswith("failed")
        if self._can_log is not None:
            return [self._can_log_status(failed)]
        if self._acquisition is not None:
            level, message, values = self._acquisition.status()
            values["interface"] = self.settings.can_interface
            values["channel"] = self.settings.can_channel
            if failed:
                level, message = common.ERROR, self.state
            return [common.diagnostic_status(f"{NAME}: daq", level, message, values)]
        replay = self._replay
        assert replay is not None
        window = self.statistics.take_window()
        level = common.OK
        if failed:
            level = common.ERROR
        elif self.state == "waiting for subscribers":
            level = common.STALE
        values_list: list[tuple[str, object]] = [
            ("state", self.state),
            ("published", self.published),
            ("samples", replay.samples),
            ("passes", self.passes),
            ("rate", self.settings.rate),
            ("stamp_mode", replay.stamp_mode.value),
            ("recording", str(replay.recording.path)),
            *common.timing_values({"period_error": window["period_error"]}),
        ]
        message = f"replay {self.state}"
        return [common.diagnostic_status(f"{NAME}: replay", level, message, values_list)]

    def close(self) -> None:
        """Stop publishing, wait for the worker thread, write the statistics file."""
        self._stop.set()
        self._thread.join(2.0)
        self.unacknowledged = False
        ended_by_itself = self.state == "finished" and self.settings.exit_at_end
        wait_s = common.ACK_WAIT_AT_END_S if ended_by_itself else common.ACK_WAIT_S
        if self.context.ok() and not common.wait_for_acks(self._outputs.values(), wait_s):
            self.unacknowledged = True
            self.get_logger().warning(
                f"subscribers had not acknowledged every sample after {wait_s:g} s: "
                "the slowest may miss the last ones"
            )
        if self.settings.statistics_file:
            summary: dict[str, Any] = {
                "mode": self.mode,
                "state": self.state,
                "published": self.published,
                "unacknowledged": self.unacknowledged,
                "passes": self.passes,
                "period_error": self.statistics.total["period_error"].summary().as_dict(),
            }
            if self._can_log is not None:
                summary["can_log"] = self._can_log.summary()
            elif self._acquisition is not None:
                summary["daq"] = self._acquisition.summary()
            common.write_summary(self.settings.statistics_file, summary)


def main(args: list[str] | None = None) -> int:
    """The node's process (its help answered by the entry point): run until SIGINT/SIGTERM."""
    return common.run_node(
        NAME,
        args,
        PressureSourceNode,
        (BrakeHilError, ParameterException),
        lambda node: common.spin_until_signal(node, node.exit_requested),
    )
