"""What the brake_hil nodes share: QoS, messages of topics.py, parameters, diagnostics.

* :func:`declare_settings`: a node's parameters from its settings dataclass
  (:mod:`brake_hil.nodes.settings`), declared read-only with their descriptions.
* :data:`SAMPLE_QOS`: the 1 kHz sample topics are reliable, volatile, keep-last 30 000 (30 s
  at 1 kHz: a subscriber that stalls for less than that loses nothing).
* Messages of a contract topic, ``header.stamp`` = the sample's acquisition time, the value in
  the topic's field: :class:`RawMessageBuilder` (CDR bytes, for ``publish``),
  :class:`MessageBuilder` (rclpy messages), :func:`raw_reader` / :func:`value_reader`.
* :class:`PolledInput`: a subscription a node's own thread takes from (no executor).
* :func:`diagnostic_status`: ``diagnostic_msgs/msg/DiagnosticStatus`` with key-value pairs;
  nodes publish arrays of them on ``/diagnostics`` (:data:`DIAGNOSTICS_TOPIC`), the
  comparator also on ``/brake/comparison`` (:data:`COMPARISON_TOPIC`).
* :func:`wait_for_acks` before a node is destroyed, so no sample in flight is lost.

How a node process runs (rclpy started, callbacks spun, signals) is
:mod:`brake_hil.nodes.spinning`; what it does before ROS starts (help, environment, folders)
:mod:`brake_hil.nodes.entry`. Their names are importable from here too.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence
import math
from operator import attrgetter
import os
import struct
import threading
import time
from typing import TYPE_CHECKING, Any, TypeVar

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Vector3Stamped, WrenchStamped
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import FluidPressure

from brake_hil.io.stamped_cdr import FLOAT_FIELDS
from brake_hil.nodes.entry import (
    CHECKOUT,
    HELP_FLAGS,
    RECORDINGS_HOME,
    asks_for_help,
    config_path,
    is_source_checkout,
    recording_directory,
    setup_environment,
    write_summary,
)
from brake_hil.nodes.settings import parameter_specs
from brake_hil.nodes.spinning import (
    BackgroundSpinner,
    LoopNode,
    init_ros,
    make_executor,
    run_node,
    run_until_stopped,
    spin_until_signal,
    wait_for_signal,
)
from brake_hil.runtime import TimingSummary
from brake_hil.topics import TopicSpec

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

__all__ = [
    "ACK_WAIT_AT_END_S",
    "ACK_WAIT_S",
    "CHECKOUT",
    "COMPARISON_TOPIC",
    "DIAGNOSTICS_QOS",
    "DIAGNOSTICS_TOPIC",
    "ERROR",
    "HELP_FLAGS",
    "LEVEL_NAMES",
    "MESSAGE_CLASSES",
    "NS_PER_S",
    "OK",
    "RECORDINGS_HOME",
    "SAMPLE_QOS",
    "SHARED_TAKES_VARIABLE",
    "STALE",
    "WARN",
    "BackgroundSpinner",
    "LoopNode",
    "MessageBuilder",
    "PolledInput",
    "PolledSubscription",
    "RawMessageBuilder",
    "asks_for_help",
    "config_path",
    "declare_settings",
    "diagnostic_array",
    "diagnostic_status",
    "init_ros",
    "is_source_checkout",
    "make_executor",
    "message_class",
    "raw_reader",
    "recording_directory",
    "run_node",
    "run_until_stopped",
    "setup_environment",
    "spin_until_signal",
    "stamp_ns",
    "status_values",
    "timing_values",
    "value_reader",
    "wait_for_acks",
    "wait_for_signal",
    "write_summary",
]

DIAGNOSTICS_TOPIC = "/diagnostics"
"""Where every node publishes its health (``diagnostic_msgs/msg/DiagnosticArray``)."""
COMPARISON_TOPIC = "/brake/comparison"
"""Where the comparator publishes its metrics (``diagnostic_msgs/msg/DiagnosticArray``)."""

OK, WARN, ERROR, STALE = 0, 1, 2, 3
"""``DiagnosticStatus`` levels."""
LEVEL_NAMES = {OK: "OK", WARN: "WARN", ERROR: "ERROR", STALE: "STALE"}

SAMPLE_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=30_000,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""QoS of the 1 kHz sample and prediction topics: reliable, with 30 s of history, so a
subscriber (the recorder) starved for seconds on a busy host still receives every sample
(with 1 s, a recorder on a 2-core host at load 5-9 lost 11 of 4000; with 5 s, a host where
the nodes took 2.5 times their usual CPU time lost 4495 of 36 000). Fast DDS caps any history
at 5000 samples unless its resource limits are raised: the loopback profile
(``config/fastdds_loopback.xml``) raises them; under another profile (SUBNET, the user's)
the history is what that profile allows."""
DIAGNOSTICS_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=100,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)

MESSAGE_CLASSES: dict[str, Any] = {
    "sensor_msgs/msg/FluidPressure": FluidPressure,
    "geometry_msgs/msg/WrenchStamped": WrenchStamped,
    "geometry_msgs/msg/Vector3Stamped": Vector3Stamped,
}
NS_PER_S = 1_000_000_000
SettingsT = TypeVar("SettingsT", bound="DataclassInstance")


def message_class(spec: TopicSpec) -> Any:
    """The rclpy message class of a contract topic."""
    return MESSAGE_CLASSES[spec.msgtype]


def stamp_ns(message: Any) -> int:
    """``header.stamp`` of a message (ns since the epoch)."""
    stamp = message.header.stamp
    return int(stamp.sec) * NS_PER_S + int(stamp.nanosec)


def raw_reader(spec: TopicSpec) -> Callable[[bytes], tuple[int, float]]:
    """Reads ``(stamp_ns, value)`` from a serialised (CDR) message of a contract topic.

    For ``raw=True`` subscriptions: at 1 kHz per topic, decoding two numbers at known offsets
    (the layout of :mod:`brake_hil.io.stamped_cdr`) costs far less than rclpy's conversion
    to a Python message.

    Raises (from the returned function):
        struct.error: a message too short for its type.
    """
    index = FLOAT_FIELDS[spec.msgtype].index(spec.field)
    little, big = struct.Struct("<iII"), struct.Struct(">iII")
    little_value, big_value = struct.Struct("<d"), struct.Struct(">d")

    def read(data: bytes) -> tuple[int, float]:
        header, value = (little, little_value) if data[1] else (big, big_value)
        sec, nanosec, frame_id_size = header.unpack_from(data, 4)
        offset = 4 + ((12 + frame_id_size + 7) // 8) * 8 + 8 * index
        return sec * NS_PER_S + nanosec, value.unpack_from(data, offset)[0]

    return read


def _never_called(message: Any) -> None:
    del message


SHARED_TAKES_VARIABLE = "BRAKE_HIL_SHARED_TAKES"
"""Environment variable: ``1`` shares one subscription per topic among a process's nodes."""


class PolledSubscription:
    """A raw subscription that its owner's thread takes from directly, with no executor.

    :meth:`take_all` returns every message the middleware holds for it, each with rmw's
    message info (``received_timestamp``, ns since the epoch; ``publication_sequence_number``;
    ``publisher_gid``), through the same ``take`` rclpy's executors use. For a node that does
    all its work on one thread and is spun by no executor (no per-message callback dispatch,
    the GIL never contended at a deadline). The subscription's history (``qos.depth``) must
    hold what arrives between two takes.

    With ``BRAKE_HIL_SHARED_TAKES=1`` in the environment (what the ``one-paired`` layout's
    container gets), nodes of one process (one rclpy context) that poll the same topic with
    the same QoS share one subscription (:class:`_SharedTopic`): the model, the comparator and
    the recorder take each sample once from the middleware, not once each; the topic then
    shows one subscription for them all (what a publisher waiting for readers must count).
    """

    def __init__(self, node: Node, message_type: Any, topic: str, qos: QoSProfile) -> None:
        if os.environ.get(SHARED_TAKES_VARIABLE) == "1":
            self._shared = _SharedTopic.join(node, message_type, topic, qos)
        else:
            self._shared = _SharedTopic(node, message_type, topic, qos)
        self._queue = self._shared.add_consumer()

    def take_all(self) -> list[tuple[bytes, dict[str, Any]]]:
        """Every held message as ``(cdr_bytes, info)``, oldest first."""
        return self._shared.take_for(self._queue)


class _SharedTopic:
    """One raw subscription of a topic in a process, taken for every consumer that joined.

    The subscription belongs to a node of its own (``brake_hil_taps``, one per context,
    destroyed with the context), so it outlives any one consumer's node. Each take fans the
    messages out to every consumer's queue (at most ``qos.depth`` kept each, as the
    middleware's history would); a consumer's queue is emptied when it takes.
    """

    _registry: dict[tuple[int, str, str, tuple[int, int, int, int]], _SharedTopic] = {}
    _taps: dict[int, Node] = {}
    _lock = threading.Lock()

    def __init__(self, node: Node, message_type: Any, topic: str, qos: QoSProfile) -> None:
        self._subscription = node.create_subscription(
            message_type, topic, _never_called, qos, raw=True
        )
        self._depth = int(qos.depth) or None
        self._queues: list[deque[tuple[bytes, dict[str, Any]]]] = []
        self._take_lock = threading.Lock()

    @classmethod
    def join(cls, node: Node, message_type: Any, topic: str, qos: QoSProfile) -> _SharedTopic:
        """The process's subscription of ``topic`` with ``qos`` (made on first use)."""
        context = node.context
        qos_key = (int(qos.history), int(qos.depth), int(qos.reliability), int(qos.durability))
        key = (id(context), topic, f"{message_type.__module__}.{message_type.__name__}", qos_key)
        with cls._lock:
            shared = cls._registry.get(key)
            if shared is None:
                tap = cls._taps.get(id(context))
                if tap is None or not tap.context.ok():
                    tap = Node("brake_hil_taps", context=context, start_parameter_services=False)
                    cls._taps[id(context)] = tap
                    # a new context may reuse a shut-down one's id: forget its topics
                    for old in [k for k in cls._registry if k[0] == id(context)]:
                        del cls._registry[old]
                shared = cls._registry[key] = cls(tap, message_type, topic, qos)
            return shared

    def add_consumer(self) -> deque[tuple[bytes, dict[str, Any]]]:
        """A new consumer's queue: what arrives from now on."""
        queue: deque[tuple[bytes, dict[str, Any]]] = deque(maxlen=self._depth)
        with self._take_lock:
            self._queues.append(queue)
        return queue

    def take_for(
        self, queue: deque[tuple[bytes, dict[str, Any]]]
    ) -> list[tuple[bytes, dict[str, Any]]]:
        """Take what the middleware holds into every queue; empty and return ``queue``."""
        handle, msg_type = self._subscription.handle, self._subscription.msg_type
        with self._take_lock:
            with handle:
                taken = []
                while (message := handle.take_message(msg_type, True)) is not None:
                    taken.append(message)
            if len(self._queues) == 1:
                if not queue:
                    return taken
                queue.extend(taken)
            else:
                for each in self._queues:
                    each.extend(taken)
            mine = list(queue)
            queue.clear()
        return mine


class PolledInput(PolledSubscription):
    """A :class:`PolledSubscription` of a contract topic, with its value reader (``read``)."""

    def __init__(self, node: Node, spec: TopicSpec, qos: QoSProfile = SAMPLE_QOS) -> None:
        super().__init__(node, message_class(spec), spec.name, qos)
        self.spec = spec
        self.read = raw_reader(spec)


def value_reader(spec: TopicSpec) -> Callable[[Any], float]:
    """Reads the topic's value (SI) from one of its messages."""
    getter = attrgetter(spec.field)
    return lambda message: float(getter(message))


class MessageBuilder:
    """Messages of one contract topic: ``builder(stamp_ns, value)``.

    For speed at 1 kHz the builder updates and returns one message object (a new message
    costs ~5 us, an update ~0.6 us): publish it before the next call, and use a builder from
    one thread only. ``publish`` serialises at once, so the reuse is safe.
    """

    def __init__(self, spec: TopicSpec, frame_id: str) -> None:
        self._message = message_class(spec)()
        self._message.header.frame_id = frame_id
        self._stamp = self._message.header.stamp
        parent, _, self._attribute = spec.field.rpartition(".")
        self._target = attrgetter(parent)(self._message) if parent else self._message

    def __call__(self, stamp: int, value: float) -> Any:
        """The message stamped ``stamp`` (ns) with ``value``: the same object every call."""
        self._stamp.sec, self._stamp.nanosec = divmod(stamp, NS_PER_S)
        setattr(self._target, self._attribute, value)
        return self._message


class RawMessageBuilder:
    """Serialised messages of one contract topic: ``builder(stamp_ns, value) -> bytes``.

    CDR, little endian, for ``publisher.publish(bytes)``.

    The layout of :mod:`brake_hil.io.stamped_cdr` (a header, then float64 fields, the topic's
    field set and the others 0): what rclpy's ``serialize_message`` gives, padding bytes
    zeroed. At 1 kHz it saves rclpy's conversion of a Python message to C on every publish.
    """

    def __init__(self, spec: TopicSpec, frame_id: str) -> None:
        fields = FLOAT_FIELDS[spec.msgtype]
        name = frame_id.encode("utf-8") + b"\0"
        body = 4 + ((12 + len(name) + 7) // 8) * 8  # offset of the first float64
        self._template = bytearray(body + 8 * len(fields))
        self._template[0:4] = b"\x00\x01\x00\x00"
        struct.pack_into("<I", self._template, 12, len(name))
        self._template[16 : 16 + len(name)] = name
        self._value_offset = body + 8 * fields.index(spec.field)
        self._stamp = struct.Struct("<iI")
        self._value = struct.Struct("<d")

    def __call__(self, stamp: int, value: float) -> bytes:
        """The serialised message stamped ``stamp`` (ns) with ``value``."""
        sec, nanosec = divmod(stamp, NS_PER_S)
        self._stamp.pack_into(self._template, 4, sec, nanosec)
        self._value.pack_into(self._template, self._value_offset, value)
        return bytes(self._template)


ACK_WAIT_S = 8.0
"""How long a sample publisher waits at its end for its subscribers' acknowledgements (s).

Under load a subscriber (the recorder) can lag its publisher by seconds; what it has not
acknowledged when the publisher's participant is destroyed is lost (a replay that exited
after 1 s lost the last 4.9 s of its samples to a recorder on a machine at load 10). Under the
10 s a launcher gives a node after SIGINT."""
ACK_WAIT_AT_END_S = 60.0
"""How long a replay that ended by itself (``exit_at_end``) waits for acknowledgements (s).

No launcher's SIGINT deadline runs then, and a recorder starved for seconds on a busy runner
catches up only after the replay: 20 s was too short for a consumer process that got a sixth
of a core beside two busy processes (the chain's ``paired`` layout lost 9 897 samples, the
source's publishers destroyed with them unacknowledged). The wait ends at the last
acknowledgement; as long as the recorder's own catch-up (``RECORDER_CATCH_UP_S``)."""


def wait_for_acks(publishers: Iterable[Any], timeout_s: float = ACK_WAIT_S) -> bool:
    """Wait until every reliable subscriber has acknowledged what ``publishers`` sent.

    Call it before the node is destroyed: samples still in flight would be lost. True when all
    were.
    """
    from rclpy.duration import Duration

    deadline = time.monotonic() + timeout_s
    acked = True
    for publisher in publishers:
        left = max(0.0, deadline - time.monotonic())
        acked = publisher.wait_for_all_acked(Duration(nanoseconds=round(left * 1e9))) and acked
    return acked


def declare_settings(node: Node, settings: type[SettingsT]) -> SettingsT:
    """Declare every field of a settings dataclass as a read-only ROS parameter.

    Returns the dataclass filled with the parameters' values.

    Each parameter gets the field's default (a ``package_file`` default as that file of
    :func:`config_path`) and its description and unit in the ``ParameterDescriptor``
    (:mod:`brake_hil.nodes.settings`).

    Raises:
        rclpy.exceptions.ParameterException: a value of the wrong type (from rclpy).
    """
    values: dict[str, Any] = {}
    for spec in parameter_specs(settings):
        default = spec.default
        if spec.package_file:
            default = str(config_path(spec.package_file_name))
        descriptor = ParameterDescriptor(description=spec.text, read_only=True)
        ros_default = list(default) if isinstance(default, tuple) else default
        value = node.declare_parameter(spec.name, ros_default, descriptor).value
        values[spec.name] = spec.convert(value)
    return settings(**values)


def _text(value: object) -> str:
    if isinstance(value, float):
        return "nan" if math.isnan(value) else f"{value:.6g}"
    return str(value)


def diagnostic_status(
    name: str,
    level: int,
    message: str,
    values: Mapping[str, object] | Iterable[tuple[str, object]] = (),
    hardware_id: str = "brake_hil",
) -> DiagnosticStatus:
    """A ``DiagnosticStatus``; floats are written with 6 significant digits."""
    status = DiagnosticStatus()
    status.level = bytes([level])
    status.name = name
    status.message = message
    status.hardware_id = hardware_id
    pairs = values.items() if isinstance(values, Mapping) else values
    status.values = [KeyValue(key=key, value=_text(value)) for key, value in pairs]
    return status


def diagnostic_array(node: Node, statuses: Sequence[DiagnosticStatus]) -> DiagnosticArray:
    """A ``DiagnosticArray`` stamped now."""
    array = DiagnosticArray()
    array.header.stamp = node.get_clock().now().to_msg()
    array.status = list(statuses)
    return array


def timing_values(summaries: Mapping[str, TimingSummary]) -> list[tuple[str, object]]:
    """Key-value pairs ``<name>_median_us``, ``_p99_us``, ``_p999_us``, ``_max_us``."""
    pairs: list[tuple[str, object]] = []
    for name, summary in summaries.items():
        if summary.samples == 0:
            continue
        pairs += [
            (f"{name}_median_us", summary.median_us),
            (f"{name}_p99_us", summary.p99_us),
            (f"{name}_p999_us", summary.p999_us),
            (f"{name}_max_us", summary.max_us),
        ]
    return pairs


def status_values(status: DiagnosticStatus) -> dict[str, str]:
    """The key-value pairs of a ``DiagnosticStatus`` as a dict."""
    return {pair.key: pair.value for pair in status.values}
