"""What the brake_hil nodes share: environment, QoS, messages of topics.py, diagnostics, spinning.

* :func:`setup_environment` keeps DDS discovery on loopback unless the caller chose otherwise.
* :data:`SAMPLE_QOS`: the 1 kHz sample topics are reliable, volatile, keep-last 1000 (one
  second at 1 kHz: a subscriber that stalls for less than that loses nothing).
* :class:`MessageBuilder` / :func:`value_reader`: one message per sample of a contract topic,
  ``header.stamp`` = the sample's acquisition time, the value in the topic's field.
* :func:`diagnostic_status`: ``diagnostic_msgs/msg/DiagnosticStatus`` with key-value pairs;
  nodes publish arrays of them on ``/diagnostics`` (:data:`DIAGNOSTICS_TOPIC`), the
  comparator also on ``/brake/comparison`` (:data:`COMPARISON_TOPIC`).
* :func:`spin_until_signal`: callbacks on a background executor (rclpy's EventsExecutor when
  available) until SIGINT/SIGTERM, so a node can finish its work (drain, final diagnostics,
  files) before ``destroy_node()`` / ``rclpy.shutdown()``. Start rclpy with
  :func:`init_ros` (rclpy's own signal handler off, ours on).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
import math
from operator import attrgetter
import os
from pathlib import Path
import signal
import struct
import sys
import threading
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Vector3Stamped, WrenchStamped
from rcl_interfaces.msg import ParameterDescriptor
import rclpy
from rclpy.context import Context
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import FluidPressure

from brake_hil.core.realtime import TimingSummary
from brake_hil.io.stamped_cdr import FLOAT_FIELDS
from brake_hil.topics import TopicSpec

DIAGNOSTICS_TOPIC = "/diagnostics"
"""Where every node publishes its health (``diagnostic_msgs/msg/DiagnosticArray``)."""
COMPARISON_TOPIC = "/brake/comparison"
"""Where the comparator publishes its metrics (``diagnostic_msgs/msg/DiagnosticArray``)."""

OK, WARN, ERROR, STALE = 0, 1, 2, 3
"""``DiagnosticStatus`` levels."""
LEVEL_NAMES = {OK: "OK", WARN: "WARN", ERROR: "ERROR", STALE: "STALE"}

SAMPLE_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1000,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""QoS of the 1 kHz sample and prediction topics."""
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


def setup_environment() -> None:
    """DDS discovery on loopback only, unless ``ROS_AUTOMATIC_DISCOVERY_RANGE`` is set."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")


def init_ros(args: Sequence[str] | None) -> None:
    """``rclpy.init`` without rclpy's signal handlers (see :func:`spin_until_signal`)."""
    setup_environment()
    rclpy.init(
        args=list(args) if args is not None else None,
        signal_handler_options=SignalHandlerOptions.NO,
    )


def config_path(name: str) -> Path:
    """A file of ``config/`` in the checkout, else in the install's ``share/brake_hil``."""
    checkout = Path(__file__).resolve().parents[2] / "config" / name
    if checkout.is_file():
        return checkout
    return Path(sys.prefix) / "share" / "brake_hil" / "config" / name


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
        self._stamp.sec, self._stamp.nanosec = divmod(stamp, NS_PER_S)
        setattr(self._target, self._attribute, value)
        return self._message


def declare(node: Node, name: str, default: Any, description: str) -> Any:
    """Declare a read-only parameter with its description; return its value."""
    descriptor = ParameterDescriptor(description=description, read_only=True)
    return node.declare_parameter(name, default, descriptor).value


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


def make_executor(context: Context | None = None) -> Executor:
    """rclpy's EventsExecutor (callbacks dispatched from C++: about half the cost a message of
    the default executor, which matters at several kHz on 2 cores); ``BRAKE_HIL_EXECUTOR=single``
    or an rclpy without it gives the SingleThreadedExecutor."""
    if os.environ.get("BRAKE_HIL_EXECUTOR", "events") != "single":
        try:
            from rclpy.experimental import EventsExecutor
        except ImportError:  # rclpy before Jazzy
            pass
        else:
            return EventsExecutor(context=context)
    return SingleThreadedExecutor(context=context)


def spin_until_signal(node: Node, stop: threading.Event | None = None) -> bool:
    """Run ``node``'s callbacks on a background executor until SIGINT or SIGTERM (or
    ``stop`` is set, or the context shuts down); then stop the executor.

    Returns False when a callback raised (the executor stops at the first exception, which is
    logged), True otherwise: ``main`` turns False into exit status 1.
    """
    stop = stop if stop is not None else threading.Event()
    failed = threading.Event()

    def on_signal(signum: int, frame: object) -> None:
        del signum, frame
        stop.set()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    executor = make_executor()
    executor.add_node(node)
    thread = threading.Thread(
        target=_spin, args=(executor, stop, failed), name="executor", daemon=True
    )
    thread.start()
    try:
        while not stop.wait(0.1) and node.context.ok() and thread.is_alive():
            pass
    finally:
        stop.set()
        thread.join(2.0)
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        if not thread.is_alive():
            executor.shutdown()
    return not failed.is_set()


def _spin(executor: Executor, stop: threading.Event, failed: threading.Event) -> None:
    # spin_once in a loop rather than spin(): the EventsExecutor's shutdown() from another
    # thread does not return while spin() runs, and the node must outlive the executor to
    # finish its work (drain, final diagnostics) before rclpy.shutdown().
    try:
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)
    except Exception as err:  # noqa: BLE001 - the main thread ends the node
        print(f"executor stopped: {type(err).__name__}: {err}", file=sys.stderr)
        failed.set()
    finally:
        stop.set()


def now_ns() -> int:
    """Wall-clock time (ns since the epoch), the clock of ``header.stamp``."""
    return time.time_ns()
