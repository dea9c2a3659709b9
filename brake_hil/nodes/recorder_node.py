"""The recorder node's ROS side: the run recorded to MCAP.

What the node does, its topics and parameters: :mod:`brake_hil.nodes.recorder`, the
entry point (``python -m brake_hil.nodes.recorder``), which answers ``--help`` without
importing this.
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Sequence
from datetime import UTC, datetime
import importlib
import re
import sys
import threading
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)

from brake_hil.errors import RecordingWriteError
from brake_hil.io.mcap_recorder import McapRecorder
from brake_hil.nodes import common
from brake_hil.nodes.settings import RecorderSettings
from brake_hil.runtime import DeadlineLoop, Tick

LOOP_THREAD = "recorder-loop"
"""The name of the recorder's thread (what ``top -H`` shows)."""


def topic_pattern(globs: Sequence[str]) -> re.Pattern[str]:
    """One regex for topic globs: ``**`` any characters, ``*`` any but ``/``."""
    parts = []
    for glob in globs:
        escaped = re.escape(glob).replace(r"\*\*", "\0").replace(r"\*", "[^/]*")
        parts.append(escaped.replace("\0", ".*"))
    return re.compile("^(?:" + "|".join(parts) + ")$")


def message_class(msgtype: str) -> Any:
    """The Python class of ``pkg/msg/Type``; raises ImportError/AttributeError if absent."""
    package, kind, name = msgtype.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), name)


def _duration(value: Any) -> QosTime:
    nanoseconds = int(getattr(value, "nanoseconds", 0))
    return QosTime(sec=nanoseconds // 1_000_000_000, nsec=nanoseconds % 1_000_000_000)


def offered_qos(profile: QoSProfile) -> Qos:
    """A publisher's QoS as rosbags (and ``metadata.yaml``) describe it."""
    return Qos(
        history=QosHistory(int(profile.history)),
        depth=int(profile.depth),
        reliability=QosReliability(int(profile.reliability)),
        durability=QosDurability(int(profile.durability)),
        deadline=_duration(profile.deadline),
        lifespan=_duration(profile.lifespan),
        liveliness=QosLiveliness(int(profile.liveliness)),
        liveliness_lease_duration=_duration(profile.liveliness_lease_duration),
        avoid_ros_namespace_conventions=bool(profile.avoid_ros_namespace_conventions),
    )


class RecorderNode(Node):
    """Subscribes to matching topics as they appear and streams them into a recording."""

    def __init__(self, cli_args: Sequence[str] | None = None) -> None:
        """Build the node (``cli_args``: its own ROS arguments); it records at once."""
        super().__init__("recorder", cli_args=list(cli_args) if cli_args is not None else None)
        self.settings = settings = common.declare_settings(self, RecorderSettings)
        bag_name = settings.bag_name
        if not bag_name:
            bag_name = "brake_hil_" + datetime.now(UTC).strftime("%Y_%m_%d-%H_%M_%S")
        self.bag_path = common.recording_directory(settings.output_dir) / bag_name
        self._recorder = McapRecorder(
            self.bag_path,
            max_file_bytes=settings.max_file_bytes or None,
            max_file_duration_s=settings.max_file_duration_s or None,
            chunk_bytes=settings.chunk_bytes,
            max_chunk_age_s=settings.flush_interval_s,
            metadata_interval_s=settings.metadata_interval_s or None,
            custom_data={"recorder": "brake_hil recorder"},
        )
        self.stop = threading.Event()
        """Set when the node must end (a failed write, a failed loop)."""
        self.write_error: RecordingWriteError | None = None
        """Why writing stopped; None while healthy."""
        self._diagnostics = self.create_publisher(
            DiagnosticArray, common.DIAGNOSTICS_TOPIC, common.DIAGNOSTICS_QOS
        )
        self._pattern = topic_pattern(settings.topics)
        self._recorded: dict[str, tuple[int, common.PolledSubscription]] = {}
        self._skipped: set[str] = set()
        self._held: list[tuple[int, int, bytes]] = []  # received after the last take began
        self._last_log_ns: dict[int, int] = {}  # per topic handle: the newest log time taken
        self._next_discovery_ns = 0
        self._next_flush_ns = 0
        self.get_logger().info(f"recording {list(settings.topics)} into {self.bag_path}")
        self._discover()
        self._loop = DeadlineLoop(
            self._tick,
            period_ns=max(1, round(settings.take_interval_s * 1e9)),
            spin_ns=0,
            on_error=self._on_loop_error,
            name=LOOP_THREAD,
        )
        self._loop.start()

    # -- the loop ------------------------------------------------------------------------

    @property
    def running(self) -> bool:
        """True while the recorder's thread runs."""
        return self._loop.running

    @property
    def loop_error(self) -> BaseException | None:
        """What stopped the loop (None: healthy, or stopped when asked)."""
        return self._loop.error

    def _on_loop_error(self, err: BaseException) -> None:
        self.get_logger().error(f"recorder loop stopped: {type(err).__name__}: {err}")
        self.stop.set()

    def _tick(self, tick: Tick) -> None:
        del tick
        if self.write_error is not None:
            self._loop.stop()
            return
        now = time.monotonic_ns()
        if now >= self._next_discovery_ns:
            self._next_discovery_ns = now + round(self.settings.discovery_interval_s * 1e9)
            self._discover()
        self._record(final=False)
        if now >= self._next_flush_ns:
            self._next_flush_ns = now + round(self.settings.flush_interval_s * 1e9)
            self._flush()

    def _record(self, final: bool) -> int:
        """Take what every subscription holds and write it in receive-time order.

        Messages received after the take began wait for the next take (unless ``final``), so
        log times never go backwards. Returns how many messages were taken.
        """
        cutoff = time.time_ns()
        batch = self._held
        taken = 0
        for handle, subscription in self._recorded.values():
            last = self._last_log_ns.get(handle, 0)
            for data, info in subscription.take_all():
                # Delivery order is the topic's order: a sample repaired after a gap was
                # received after newer ones, and is logged no earlier than its predecessor.
                last = max(last, int(info.get("received_timestamp", 0)) or cutoff)
                batch.append((last, handle, data))
                taken += 1
            self._last_log_ns[handle] = last
        batch.sort(key=lambda entry: entry[0])  # stable: each topic keeps its order
        split = len(batch) if final else bisect_right(batch, cutoff, key=lambda e: e[0])
        self._held = batch[split:]
        write = self._recorder.write
        try:
            for log_time, handle, data in batch[:split]:
                write(handle, log_time, data)
        except RecordingWriteError as err:
            self._stop_writing(err)
        return taken

    def _flush(self) -> None:
        if self.write_error is not None:
            return
        try:
            self._recorder.flush()
        except RecordingWriteError as err:
            self._stop_writing(err)

    def _stop_writing(self, err: RecordingWriteError) -> None:
        """Stop at the first failed write; :func:`main` reports it and ends the node."""
        self.write_error = err
        self.stop.set()

    def report_write_error(self) -> None:
        """Publish the failed write as an ERROR on ``/diagnostics`` and wait for the acks."""
        if self.write_error is None:
            return
        on_disk = sum(f.message_count for f in self._recorder.files())
        status = common.diagnostic_status(
            "recorder",
            common.ERROR,
            f"recording stopped: {self.write_error}",
            {"bag": str(self.bag_path), "messages_on_disk": on_disk},
        )
        self._diagnostics.publish(common.diagnostic_array(self, [status]))
        common.wait_for_acks([self._diagnostics], timeout_s=2.0)

    # -- topics --------------------------------------------------------------------------

    def _discover(self) -> None:
        if self.write_error is not None:
            return
        for name, types in self.get_topic_names_and_types():
            if name in self._recorded or name in self._skipped:
                continue
            if not self._pattern.match(name):
                continue
            if len(types) != 1:
                self.get_logger().warning(f"{name} has types {types}; recording {types[0]}")
            self._subscribe(name, types[0])

    def _subscribe(self, name: str, msgtype: str) -> None:
        try:
            cls = message_class(msgtype)
        except (ImportError, AttributeError, ValueError) as err:
            self.get_logger().warning(f"not recording {name}: type {msgtype} unavailable ({err})")
            self._skipped.add(name)
            return
        publishers = self.get_publishers_info_by_topic(name)
        offered = [offered_qos(info.qos_profile) for info in publishers]
        best_effort = any(q.reliability == QosReliability.BEST_EFFORT for q in offered)
        reliability = ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE
        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=self.settings.qos_depth,
            reliability=reliability,
            durability=DurabilityPolicy.VOLATILE,
        )
        try:
            handle = self._recorder.add_topic(name, msgtype, offered_qos_profiles=offered)
        except RecordingWriteError as err:
            self._stop_writing(err)
            return
        except ValueError as err:
            self.get_logger().warning(f"not recording {name}: {err}")
            self._skipped.add(name)
            return
        subscription = common.PolledSubscription(self, cls, name, qos)
        self._recorded[name] = (handle, subscription)
        self.get_logger().info(f"recording {name} ({msgtype})")

    # -- the end -------------------------------------------------------------------------

    @property
    def message_count(self) -> int:
        """Messages recorded so far."""
        return int(self._recorder.message_count)

    def stop_loop(self) -> None:
        """Stop the recorder's thread (after its current take); idempotent."""
        self._loop.stop()

    def drain(self, quiet_s: float = 0.05, timeout_s: float = 0.5) -> None:
        """Record what the middleware still holds.

        Take until nothing arrives for ``quiet_s`` (at most ``timeout_s``). Called after the
        loop stopped (:meth:`stop_loop`), before :meth:`close`.
        """
        self.stop_loop()
        deadline = time.monotonic() + timeout_s
        quiet_since = time.monotonic()
        while self.write_error is None and (now := time.monotonic()) < deadline:
            if self._record(final=True):
                quiet_since = now
            elif now - quiet_since >= quiet_s:
                break
            time.sleep(0.005)

    def finish_recording(self) -> bool:
        """Stop the loop and record what the middleware still holds (:meth:`drain`).

        Returns False after a failed write (published as an ERROR on ``/diagnostics``, one
        line on stderr) or a failed loop; call :meth:`close` next.
        """
        self.stop_loop()
        if self.write_error is None:
            self.drain()
        if self.write_error is not None:
            self.report_write_error()
            print(f"recorder: error: {self.write_error}", file=sys.stderr)
            return False
        return self.loop_error is None

    def close(self) -> None:
        """Finish the recording: last chunk, summaries, ``metadata.yaml``.

        After a failed write the files are closed as they stand (nothing raised); a write
        that fails while finishing is reported as in :meth:`report_write_error`.
        """
        self.stop_loop()
        failed_before = self.write_error is not None
        try:
            self._recorder.close()
        except RecordingWriteError as err:
            self.write_error = err
            self.report_write_error()
            print(f"recorder: error: {err}", file=sys.stderr)
            return
        if failed_before:
            return
        files = ", ".join(f.path.name for f in self._recorder.files())
        self.get_logger().info(
            f"closed {self.bag_path}: {self._recorder.message_count} messages in {files}"
        )


def main(args: list[str] | None = None) -> int:
    """The node's process (its help answered by the entry point).

    Record until SIGINT/SIGTERM, then drain and finish.
    """

    def run(node: RecorderNode) -> bool:
        common.wait_for_signal(lambda: node.stop.is_set() or not node.running)
        return node.finish_recording()

    nodes: list[RecorderNode] = []

    def make_node() -> RecorderNode:
        nodes.append(RecorderNode())
        return nodes[-1]

    # OSError, ValueError: the bag exists, the directory is not writable.
    status = common.run_node("recorder", args, make_node, (OSError, ValueError), run)
    if status == 0 and nodes and nodes[0].write_error is not None:
        return 1  # the last chunk or the summary could not be written at the end
    return status
