"""Nodes of one process share one subscription per topic when asked (``one-paired``)."""

from __future__ import annotations

from collections.abc import Iterator
import time

import pytest
import rclpy
from rclpy.context import Context
from rclpy.node import Node

from brake_hil.app.chain_layouts import LAYOUTS, SHARED_TAKES, readers_per_topic
from brake_hil.nodes import common
from brake_hil.topics import MASTER_CYLINDER_PRESSURE


@pytest.fixture
def context() -> Iterator[Context]:
    context = Context()
    rclpy.init(context=context)
    try:
        yield context
    finally:
        rclpy.shutdown(context=context)


def _two_readers_and_a_writer(context: Context) -> tuple[Node, list[common.PolledInput], int]:
    """Two nodes polling p_i, a third publishing 50 samples; the subscriptions on the graph."""
    readers = [Node(name, context=context) for name in ("reader_a", "reader_b")]
    inputs = [common.PolledInput(node, MASTER_CYLINDER_PRESSURE) for node in readers]
    writer = Node("writer", context=context)
    spec = MASTER_CYLINDER_PRESSURE
    publisher = writer.create_publisher(common.message_class(spec), spec.name, common.SAMPLE_QOS)
    deadline = time.monotonic() + 30.0
    while publisher.get_subscription_count() < 1 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)  # every reader matched
    build = common.RawMessageBuilder(spec, "rig")
    for index in range(50):
        publisher.publish(build(1_000_000_000 + index * 1_000_000, float(index)))
    return writer, inputs, int(writer.count_subscribers(spec.name))


def _take_until(polled: common.PolledInput, count: int) -> list[float]:
    values: list[float] = []
    deadline = time.monotonic() + 30.0
    while len(values) < count and time.monotonic() < deadline:
        values += [polled.read(data)[1] for data, _ in polled.take_all()]
        time.sleep(0.01)
    return values


def test_shared_takes_give_every_node_every_sample_from_one_subscription(
    context: Context, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(common.SHARED_TAKES_VARIABLE, "1")
    _, (first, second), subscriptions = _two_readers_and_a_writer(context)
    assert subscriptions == 1  # one subscription for both nodes
    expected = [float(index) for index in range(50)]
    assert _take_until(first, 50) == expected
    assert _take_until(second, 50) == expected  # taken by the first, kept for the second
    assert first.take_all() == [] and second.take_all() == []


def test_without_the_variable_each_node_has_its_own_subscription(
    context: Context, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(common.SHARED_TAKES_VARIABLE, raising=False)
    _, (first, second), subscriptions = _two_readers_and_a_writer(context)
    assert subscriptions == 2
    assert _take_until(first, 50) == _take_until(second, 50) == [float(i) for i in range(50)]


def test_the_source_waits_for_one_subscription_per_process_where_takes_are_shared() -> None:
    assert readers_per_topic("processes") == {"p_i": 2, "measured": 2, "predicted": 2}
    assert readers_per_topic("processes", recorder=False) == {
        "p_i": 1,
        "measured": 1,
        "predicted": 1,
    }
    assert readers_per_topic("paired") == {"p_i": 2, "measured": 2, "predicted": 2}
    for layout in SHARED_TAKES:
        assert set(LAYOUTS[layout].values()) == {"container"}
        assert readers_per_topic(layout) == {"p_i": 1, "measured": 1, "predicted": 1}
