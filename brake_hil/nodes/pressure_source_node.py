"""The pressure_source node's ROS side: the rig's ``p_i`` and measurements on the graph.

What the node does, its topics and parameters: :mod:`brake_hil.nodes.pressure_source`, the
entry point (``python -m brake_hil.nodes.pressure_source``), which answers ``--help`` without
importing this.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
import threading
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.exceptions import ParameterException
from rclpy.node import Node

from brake_hil.analysis.recording import Recording
from brake_hil.errors import BrakeHilError
from brake_hil.io.recording_reader import read_recording
from brake_hil.nodes import common
from brake_hil.nodes.pressure_source import NAME
from brake_hil.nodes.settings import PressureSourceSettings
from brake_hil.runtime import (
    LoopStatistics,
    StampMode,
    loop_span_ns,
    replay_deadlines,
    set_process_realtime_priority,
    set_realtime_priority,
    set_timer_slack,
    sleep_until,
)
from brake_hil.topics import (
    AIR_PRESSURE,
    BLOCK_FORCE,
    BORE_PRESSURE,
    CALIPER_DISPLACEMENT,
    MASTER_CYLINDER_PRESSURE,
    QUANTITY_TOPICS,
    TopicSpec,
)


def replay_channels(recording: Recording, publish_measured: bool) -> dict[TopicSpec, Any]:
    """The recording's channels to publish, keyed by topic (``p_i`` first)."""
    channels: dict[TopicSpec, Any] = {MASTER_CYLINDER_PRESSURE: recording.master_cylinder_pressure}
    if publish_measured:
        for spec, values in (
            (BORE_PRESSURE, recording.bore_pressure),
            (BLOCK_FORCE, recording.block_force),
            (CALIPER_DISPLACEMENT, recording.caliper_displacement),
            (AIR_PRESSURE, recording.air_pressure),
        ):
            if values is not None:
                channels[spec] = values
    return channels


class PressureSourceNode(Node):
    """Replays a recording, or acquires from the rig's CAN DAQ, onto the contract topics."""

    def __init__(self, cli_args: Sequence[str] | None = None, own_process: bool = True) -> None:
        """Build the node; its worker thread starts at once.

        Args:
            cli_args: the node's own ROS arguments (``--ros-args ...``), beside the process's
                (rclpy ``Node(cli_args=...)``): how a container gives each node its own.
            own_process: False when the node shares its process with others (the container):
                then ``realtime_priority`` sets only the worker thread's scheduling, not every
                thread's of the process.
        """
        super().__init__(NAME, cli_args=list(cli_args) if cli_args is not None else None)
        self.settings = settings = common.declare_settings(self, PressureSourceSettings)
        self.mode = settings.mode
        if settings.rate <= 0.0:
            raise BrakeHilError(f"rate must be positive, got {settings.rate}")

        self.statistics = LoopStatistics()
        self.published = 0  # samples (p_i messages)
        self.passes = 0  # replay passes completed
        self.state = "starting"
        self._stop = threading.Event()
        self.exit_requested = threading.Event()  # set at the end of a replay with exit_at_end
        self._diagnostics = self.create_publisher(
            DiagnosticArray, common.DIAGNOSTICS_TOPIC, common.DIAGNOSTICS_QOS
        )
        self._outputs: dict[TopicSpec, Any] = {}
        self._builders: dict[TopicSpec, common.RawMessageBuilder] = {}
        self._daq: Any = None
        self._status_lock = threading.Lock()
        self._last_status: Any = None
        self._rearm = threading.Event()
        self.stale_reports_ms: list[float] = []  # last good frame to STALE published (ms)
        # Paired nodes (one container): ticked after each replayed sample, told at its end.
        self._followers: list[Callable[[int, int], None]] = []
        self._on_replay_end: list[Callable[[], None]] = []
        self._pair_lock = threading.Lock()
        self._replay_over = False
        if self.mode == "replay":
            self._prepare_replay(
                settings.recording, settings.stamp_mode, settings.publish_measured
            )
            target: Callable[[], None] = self._replay
        elif self.mode == "can":
            self._prepare_can(settings.publish_measured)
            target = self._acquire
        else:
            raise BrakeHilError(f"mode must be replay or can, got {self.mode!r}")
        self.create_timer(settings.diagnostics_period, self._report)
        if settings.realtime_priority > 0 and own_process:
            # the worker one step above the node's other threads
            set_process_realtime_priority(max(1, settings.realtime_priority - 1))
        self._thread = threading.Thread(target=self._guarded(target), name=NAME, daemon=True)
        self._thread.start()

    def _advertise(self, specs: list[TopicSpec]) -> None:
        for spec in specs:
            self._outputs[spec] = self.create_publisher(
                common.message_class(spec), spec.name, common.SAMPLE_QOS
            )
            self._builders[spec] = common.RawMessageBuilder(spec, self.settings.frame_id)

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

    # -- replay ------------------------------------------------------------------------

    def _prepare_replay(self, path: str, stamp_mode: str, publish_measured: bool) -> None:
        if not path:
            raise BrakeHilError("replay mode needs the parameter 'recording'")
        try:
            self._stamp_mode = StampMode(stamp_mode)
        except ValueError as err:
            raise BrakeHilError(f"stamp_mode must be shift or keep, got {stamp_mode!r}") from err
        settings = self.settings
        recording = read_recording(path)
        time_s = recording.time
        keep = time_s >= settings.start_offset - 1e-9
        if settings.duration > 0.0:
            keep &= time_s < settings.start_offset + settings.duration - 1e-9
        if keep.sum() < 2:
            raise BrakeHilError(
                f"{path}: start_offset {settings.start_offset} s and duration "
                f"{settings.duration} s leave fewer than 2 of its {time_s.size} samples "
                f"({time_s[-1]:.3f} s long)"
            )
        stamps = recording.start_stamp_ns + (time_s[keep] * 1e9).round().astype("int64")
        channels = replay_channels(recording, publish_measured)
        self._stamps = stamps
        self._values = {spec: values[keep].tolist() for spec, values in channels.items()}
        self._advertise(list(channels))
        self.recording = recording
        self.get_logger().info(
            f"replaying {path}: {stamps.size} samples of {', '.join(s.name for s in channels)} "
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
                if time.monotonic() - started > 1.0:
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

    def _replay(self) -> None:
        try:
            self._play()
        finally:
            with self._pair_lock:
                self._replay_over = True
                ends, self._on_replay_end = self._on_replay_end, []
            for end in ends:
                end()

    def _play(self) -> None:
        set_timer_slack(1)
        set_realtime_priority(self.settings.realtime_priority)
        self._wait_for_graph()
        self._stop.wait(self.settings.start_delay)
        stamps = self._stamps
        span = loop_span_ns(stamps)
        start = time.monotonic_ns() + 1_000_000
        wall_start = time.time_ns() + (start - time.monotonic_ns())
        offset = wall_start - int(stamps[0]) if self._stamp_mode is StampMode.SHIFT else 0
        deadlines = replay_deadlines(stamps, start, self.settings.rate).tolist()
        pass_duration = round(span / self.settings.rate)
        stamp_list = stamps.tolist()
        specs = list(self._values)
        columns = [self._values[spec] for spec in specs]
        publishers = [self._outputs[spec] for spec in specs]
        builders = [self._builders[spec] for spec in specs]
        stats = self.statistics
        spin_ns = 1000 * self.settings.spin_margin_us
        followers = self._followers  # the list itself: a node paired later is seen
        self.state = "playing"
        while not self._stop.is_set():
            shift = self.passes * pass_duration
            stamp_shift = offset + self.passes * span
            for index, deadline in enumerate(deadlines):
                if self._stop.is_set():
                    break
                due = deadline + shift
                wake = sleep_until(due, spin_ns)
                stats.add("period_error", wake - due)
                stamp = stamp_list[index] + stamp_shift
                for column, publisher, build in zip(columns, publishers, builders):
                    publisher.publish(build(stamp, column[index]))
                self.published += 1
                for follow in followers:
                    follow(due, wake)
            else:
                self.passes += 1
                if self.settings.loop:
                    continue
            break
        if not self._stop.is_set():
            self.state = "finished"
            self.get_logger().info(f"replay finished: {self.published} samples published")
            self._report()
            if self.settings.exit_at_end:
                self.exit_requested.set()

    # -- CAN ---------------------------------------------------------------------------

    def _prepare_can(self, publish_measured: bool) -> None:
        from brake_hil.io.can_daq import CanDaq

        settings = self.settings
        options = {"sleep_after_open": settings.can_sleep_after_open}
        self._daq = CanDaq(
            settings.can_interface,
            settings.can_channel,
            settings.can_bitrate,
            dbc_path=settings.dbc_file,
            stale_after_s=settings.stale_after_ms / 1e3,
            bus_kwargs=options if settings.can_interface == "slcan" else None,
        )
        if not self._waits():  # else opened after the wait (_acquire)
            self._daq.open()  # a missing driver fails here; a missing adapter is retried
        quantities = self._daq.codec.quantities
        unknown = [q for q in quantities if q not in QUANTITY_TOPICS]
        if unknown:
            raise BrakeHilError(f"{settings.dbc_file}: no topic for the quantities {unknown}")
        self._quantities = [q for q in quantities if publish_measured or q == "p_i"]
        self._advertise([QUANTITY_TOPICS[q] for q in self._quantities])
        self.get_logger().info(
            f"acquiring {', '.join(self._quantities)} from CAN {settings.can_interface} "
            f"{settings.can_channel} at {settings.can_bitrate} bit/s"
        )

    def _waits(self) -> bool:
        """A wait for subscribers was asked for (``wait_for_subscribers``, ``wait_for_topics``)."""
        return self.settings.wait_for_subscribers > 0 or any(
            entry.strip() for entry in self.settings.wait_for_topics
        )

    def _acquire(self) -> None:
        set_timer_slack(1)
        set_realtime_priority(self.settings.realtime_priority)
        daq = self._daq
        if self._waits():
            self._wait_for_graph()  # then open: the DAQ's port opening may start the sender
        routes = {
            q: (self._outputs[QUANTITY_TOPICS[q]], self._builders[QUANTITY_TOPICS[q]])
            for q in self._quantities
        }
        self.state = "acquiring"
        # CPython's switch interval stays at 5 ms: at 0.5 ms (tried, for a prompter STALE) the
        # acquisition thread lost the GIL so often that a 3 s CAN run lost 400-600 of 3000
        # samples in the pty on a quiet 2-core machine; the watchdog is prompt under SCHED_FIFO.
        watchdog = threading.Thread(target=self._watch_stale, name="daq-stale", daemon=True)
        watchdog.start()
        with daq:
            while not self._stop.is_set():
                for sample in daq.poll(timeout=0.001):
                    stamp = sample.stamp_ns
                    for quantity, value in sample.values.items():
                        route = routes.get(quantity)
                        if route is not None:
                            route[0].publish(route[1](stamp, value))
                    if "p_i" in sample.values:
                        self.published += 1
                if not self._report_if_changed() and not self._rearm.is_set():
                    self._rearm.set()  # fresh again (or never was): the watchdog waits for it
        self._rearm.set()
        watchdog.join(1.0)

    def _report_if_changed(self) -> bool:
        """Publish the DAQ status when it differs from the last one published.

        Returns whether the status is STALE. The delay of a STALE report from the last good
        frame is kept in :attr:`stale_reports_ms`.
        """
        with self._status_lock:
            daq = self._daq
            status = daq.health().status
            stale = bool(status.value == "stale")
            if status is not self._last_status:
                self._last_status = status
                deadline = daq.stale_deadline_ns
                if stale and deadline is not None:  # kept first: the report carries it
                    since_frame = time.monotonic_ns() - deadline + daq.stale_after_s * 1e9
                    self.stale_reports_ms.append(since_frame / 1e6)
                self._report()
            return stale

    def _watch_stale(self) -> None:
        """Report STALE at the deadline armed by the last good frame (its own thread).

        Sleeps until ``daq.stale_deadline_ns`` (absolute, monotonic); a good frame meanwhile
        has moved the deadline, so it sleeps again until the new one. Past an unmoved deadline
        the status is STALE: published at once, then the watchdog waits to be re-armed by the
        acquisition thread once frames are fresh again.
        """
        set_timer_slack(1)
        set_realtime_priority(self.settings.realtime_priority)
        daq = self._daq
        while not self._stop.is_set():
            deadline = daq.stale_deadline_ns
            if deadline is None:
                self._rearm.wait(0.1)
                continue
            left = deadline - time.monotonic_ns()
            if left > 0:
                self._stop.wait(left / 1e9)
                continue
            if daq.stale_deadline_ns != deadline:
                continue  # a frame came while we woke
            self._rearm.clear()
            self._report_if_changed()
            while not self._stop.is_set() and daq.stale_deadline_ns == deadline:
                self._rearm.wait(0.1)

    # -- reporting -----------------------------------------------------------------------

    def _report(self) -> None:
        if self.context.ok():
            self._diagnostics.publish(common.diagnostic_array(self, self.statuses()))

    def statuses(self) -> list[Any]:
        """The node's diagnostics now."""
        if self.mode == "can":
            return [self._daq_status()]
        window = self.statistics.take_window()
        level = common.OK
        if self.state.startswith("failed"):
            level = common.ERROR
        elif self.state == "waiting for subscribers":
            level = common.STALE
        values: list[tuple[str, object]] = [
            ("state", self.state),
            ("published", self.published),
            ("samples", int(self._stamps.size)),
            ("passes", self.passes),
            ("rate", self.settings.rate),
            ("stamp_mode", self._stamp_mode.value),
            ("recording", str(self.recording.path)),
            *common.timing_values({"period_error": window["period_error"]}),
        ]
        return [common.diagnostic_status(f"{NAME}: replay", level, f"replay {self.state}", values)]

    def _daq_status(self) -> Any:
        health = self._daq.health()
        message = f"DAQ {health.status.value}"
        if health.last_error:
            message += f": {health.last_error}"
        if self.state.startswith("failed"):
            message = self.state
        values = {
            **{key: value for key, value in health._asdict().items() if key != "status"},
            "stale_report_ms": self.stale_reports_ms[-1] if self.stale_reports_ms else -1.0,
            "stale_reports": len(self.stale_reports_ms),
            "published": self.published,
            "interface": self.settings.can_interface,
            "channel": self.settings.can_channel,
        }
        level = common.ERROR if self.state.startswith("failed") else health.status.diagnostic_level
        return common.diagnostic_status(f"{NAME}: daq", level, message, values)

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
            if self._daq is not None:
                health = self._daq.health()._asdict()
                summary["daq"] = {k: v for k, v in health.items() if k != "status"}
                summary["daq"]["status"] = health["status"].value
                summary["daq"]["stale_reports_ms"] = self.stale_reports_ms
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
