"""Helpers of the node tests: a ROS environment per run and a collecting rclpy node.

Every node runs as its own process (``python -m brake_hil.nodes.<name>``) with
DDS local-only (the loopback profile under ``SYSTEM_DEFAULT``, see
:func:`brake_hil.runtime.loopback_environment`) and a ``ROS_DOMAIN_ID`` unique to the test run,
set both in the subprocesses' environment and in this process (for the collector node).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
import os
import threading
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
import rclpy
from rclpy.context import Context
from rclpy.node import Node

from brake_hil.app.chain import ros_environment
from brake_hil.app.chain_environment import choose_domain_id
from brake_hil.nodes import common
from brake_hil.physics.excitation import PulsingSchedule
from brake_hil.physics.rig import load_rig
from brake_hil.runtime import loopback_environment
from brake_hil.topics import TopicSpec

DDS_PROFILE_KEYS = ("FASTDDS_DEFAULT_PROFILES_FILE", "BRAKE_HIL_DDS_PROFILE")


def unique_domain_id() -> int:
    """A ROS domain id (1-100) for this test, held by this process (no other process gets it)."""
    return choose_domain_id()


@contextmanager
def ros_domain(domain_id: int) -> Iterator[dict[str, str]]:
    """Point this process at ``domain_id`` on loopback; yield the node processes' env."""
    keys = ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", *DDS_PROFILE_KEYS)
    saved = {k: os.environ.get(k) for k in keys}
    os.environ["ROS_DOMAIN_ID"] = str(domain_id)
    if os.environ.get("BRAKE_HIL_DDS_PROFILE") != "loopback":
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    loopback_environment(os.environ)  # this process's collector on loopback too
    try:
        yield ros_environment(domain_id)
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


class Collector:
    """A real rclpy node in the test process that keeps what it receives.

    Sample topics are kept as ``(stamp_ns, value, receive_ns)`` from their CDR bytes;
    ``DiagnosticArray`` topics as ``(receive_ns, message)``.
    """

    def __init__(self, samples: Sequence[TopicSpec], arrays: Sequence[str] = ()) -> None:
        self._context = Context()
        rclpy.init(context=self._context)
        self.node = Node("test_collector", context=self._context)
        self.samples: dict[str, list[tuple[int, float, int]]] = defaultdict(list)
        self.arrays: dict[str, list[tuple[int, Any]]] = defaultdict(list)
        for spec in samples:
            read = common.raw_reader(spec)
            store = self.samples[spec.name]

            def on_sample(data: bytes, read: Any = read, store: Any = store) -> None:
                store.append((*read(data), time.time_ns()))

            self.node.create_subscription(
                common.message_class(spec), spec.name, on_sample, common.SAMPLE_QOS, raw=True
            )
        for topic in arrays:
            store_array = self.arrays[topic]

            def on_array(message: Any, store: Any = store_array) -> None:
                store.append((time.time_ns(), message))

            self.node.create_subscription(DiagnosticArray, topic, on_array, common.DIAGNOSTICS_QOS)
        self._stop = threading.Event()
        self._executor = common.make_executor(self._context)
        self._executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set():
            self._executor.spin_once(timeout_sec=0.05)

    def publishers(self, topic: str) -> int:
        """Publishers of ``topic`` seen on the graph."""
        return int(self.node.count_publishers(topic))

    def wait_for_publishers(self, topics: Sequence[str], timeout_s: float = 30.0) -> bool:
        """True once every topic has a publisher."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if all(self.publishers(t) for t in topics):
                return True
            time.sleep(0.05)
        return False

    def close(self) -> None:
        """Stop spinning and shut this node's context down."""
        self._stop.set()
        self._thread.join(2.0)
        self._executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self._context)


def emulated_run(run: dict[str, Any], **schedule: float) -> Any:
    """The run the rig emulator plays for the settings ``run`` (simulator, seed), offline.

    On the default rig; ``schedule``: the pulsing schedule's ramp and pulsing seconds
    (``run``'s own unless given).
    """
    from brake_hil.nodes.rig_emulator_node import precompute_run

    timing = {"ramp_s": run["ramp_s"], "pulsing_s": run["pulsing_s"], **schedule}
    return precompute_run(
        load_rig(common.config_path("rig_default.yaml")),
        run["simulator"],
        schedule=PulsingSchedule(**timing),
        seed=run["seed"],
    )
