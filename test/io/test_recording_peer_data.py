"""Real rosbag2 bags (rosbag2's own test resources) open, and say clearly what is missing."""

from __future__ import annotations

from pathlib import Path

import pytest

from brake_hil.errors import MissingTopicError
from brake_hil.io.recording_reader import list_topics, read_recording

BAGS = {
    "mcap/talker": {"/topic", "/rosout", "/parameter_events"},
    "mcap/wbag": {"AAA", "BBB", "CCC", "DDD", "EEE", "FFF", "GGG", "HHH"},
    "mcap/cdr_test": {"/array_topic", "/test_topic"},
    "mcap/bag_with_topics_and_service_events": {
        "/events/write_split",
        "/test_service1/_service_event",
        "/test_service2/_service_event",
        "/test_topic1",
        "/test_topic2",
    },
    "sqlite3/talker": {"/topic", "/rosout", "/parameter_events"},
    "sqlite3/wbag": {"AAA", "BBB", "CCC", "DDD", "EEE", "FFF", "GGG", "HHH"},
}


@pytest.mark.parametrize("bag", BAGS)
def test_peer_bag_without_brake_topics_names_the_missing_input_and_what_is_there(
    peer_data: Path, bag: str
) -> None:
    path = peer_data / bag
    with pytest.raises(MissingTopicError) as caught:
        read_recording(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: missing topic /brake/master_cylinder/pressure;")
    assert message.count("/brake/master_cylinder/pressure") == 1
    assert "\n" not in message
    for topic in BAGS[bag]:
        assert f"{topic} (" in message


@pytest.mark.parametrize("bag", BAGS)
def test_list_topics_opens_every_peer_bag(peer_data: Path, bag: str) -> None:
    topics = list_topics(peer_data / bag)

    assert {t.name for t in topics} == BAGS[bag]
    assert all(t.msgtype and t.message_count >= 0 for t in topics)
    assert [t.name for t in topics] == sorted(t.name for t in topics)


def test_list_topics_counts_messages_as_ros2_bag_info_does(peer_data: Path) -> None:
    talker = {t.name: (t.msgtype, t.message_count) for t in list_topics(peer_data / "mcap/talker")}
    assert talker["/topic"] == ("std_msgs/msg/String", 10)
    wbag = list_topics(peer_data / "mcap/wbag")  # split over five files
    assert sum(t.message_count for t in wbag) == 6074


@pytest.mark.parametrize(
    "storage_file",
    [
        "mcap/talker/talker.mcap",
        "mcap/wbag/wbag_2.mcap",
        "mcap/bag_with_topics_and_service_events/bag_with_topics_and_service_events.mcap",
        "sqlite3/talker/talker.db3",
    ],
)
def test_a_peer_storage_file_on_its_own_opens_too(peer_data: Path, storage_file: str) -> None:
    path = peer_data / storage_file
    assert list_topics(path)
    with pytest.raises(MissingTopicError, match="/brake/master_cylinder/pressure"):
        read_recording(path)
