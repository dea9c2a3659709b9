"""Helpers of the fault tests: a real publisher of contract samples in the test process.

The node under test runs as its own process (:func:`brake_hil.app.chain.start_node`); this
node publishes what a faulty upstream would (NaN, absurd values, stamps going backwards) on
the same QoS as the project's nodes, waiting until the node under test has subscribed.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
import time

import rclpy
from rclpy.context import Context
from rclpy.node import Node

from brake_hil.app.chain import NodeProcess, start_node
from brake_hil.nodes import common
from brake_hil.topics import TopicSpec

MS = 1_000_000


class SamplePublisher:
    """Publishes ``(stamp_ns, value)`` samples of one contract topic (or more), paced."""

    def __init__(self, spec: TopicSpec, *more: TopicSpec) -> None:
        self._context = Context()
        rclpy.init(context=self._context)
        self.node = Node("test_fault_source", context=self._context)
        specs = (spec, *more)
        self._builds = [common.RawMessageBuilder(s, "test") for s in specs]
        self.publishers = [
            self.node.create_publisher(common.message_class(s), s.name, common.SAMPLE_QOS)
            for s in specs
        ]
        self.publisher = self.publishers[0]

    def wait_for_subscribers(self, count: int, timeout_s: float = 30.0) -> bool:
        """True once ``count`` subscriptions have matched every publisher."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if all(p.get_subscription_count() >= count for p in self.publishers):
                return True
            time.sleep(0.05)
        return False

    def publish(self, samples: Iterable[tuple[int, float]], period_s: float = 0.001) -> None:
        """Publish each sample of the first topic, one per ``period_s`` (absolute schedule)."""
        self.publish_rows(([(stamp, value)] for stamp, value in samples), period_s)

    def publish_rows(
        self, rows: Iterable[Sequence[tuple[int, float]]], period_s: float = 0.001
    ) -> None:
        """Publish one ``(stamp_ns, value)`` per topic each ``period_s`` (absolute schedule)."""
        start = time.monotonic()
        for k, row in enumerate(rows):
            delay = start + k * period_s - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            for publisher, build, (stamp, value) in zip(self.publishers, self._builds, row):
                publisher.publish(build(stamp, value))
        common.wait_for_acks(self.publishers, 10.0)

    def close(self) -> None:
        """Destroy the node and shut its context down."""
        self.node.destroy_node()
        rclpy.shutdown(context=self._context)


def start_can_source(
    link: Path, env: Mapping[str, str], out: Path, stale_after_ms: float, **parameters: object
) -> NodeProcess:
    """``pressure_source`` reading a DAQ over slcan at ``link`` (logs in ``out/logs``)."""
    settings = {
        "mode": "can",
        "can_interface": "slcan",
        "can_channel": str(link),
        "stale_after_ms": stale_after_ms,
        **parameters,
    }
    return start_node("pressure_source", settings, env, out / "logs")
