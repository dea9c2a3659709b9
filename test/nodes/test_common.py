"""The nodes' shared helpers: CDR built and read by hand agree with rclpy's serialisation."""

from __future__ import annotations

import pytest
from rclpy.serialization import deserialize_message, serialize_message

from brake_hil.nodes import common
from brake_hil.topics import ALL_TOPICS, TopicSpec

STAMP = 1_700_000_000_123_456_789


@pytest.mark.parametrize("spec", ALL_TOPICS, ids=lambda spec: spec.name)
@pytest.mark.parametrize("frame_id", ["", "c", "caliper", "abcdefgh", "rig/left caliper"])
def test_raw_messages_are_what_rclpy_serialises(spec: TopicSpec, frame_id: str) -> None:
    message = common.MessageBuilder(spec, frame_id)(STAMP, -3.25e5)
    raw = common.RawMessageBuilder(spec, frame_id)(STAMP, -3.25e5)
    serialised = serialize_message(message)
    assert len(raw) == len(serialised)
    assert deserialize_message(raw, common.message_class(spec)) == message
    read = common.raw_reader(spec)
    assert read(raw) == read(serialised) == (STAMP, -3.25e5)
    assert common.stamp_ns(message) == STAMP
    assert common.value_reader(spec)(message) == -3.25e5


def test_diagnostic_status_carries_level_and_text_values() -> None:
    status = common.diagnostic_status(
        "node: part", common.WARN, "late", {"p99_us": 123.456789, "ticks": 7, "nan": float("nan")}
    )
    assert status.level == bytes([common.WARN])
    assert common.status_values(status) == {"p99_us": "123.457", "ticks": "7", "nan": "nan"}
