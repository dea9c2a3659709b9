"""The streaming rosbag2 MCAP writer: round trip, splitting, and what a killed writer leaves.

A ``kill -9`` leaves exactly what the writer had put on disk, since it buffers nothing outside
its own pending chunk; so reading the directory while the writer is still open (without
closing it) is what a reader sees after the kill.
"""

from __future__ import annotations

from operator import attrgetter
from pathlib import Path
import shutil
import subprocess
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
import numpy as np
import pytest
from rosbags.rosbag2 import Reader
import yaml

from brake_hil.io.mcap_recorder import McapRecorder, recover_metadata
from brake_hil.io.recording_reader import read_recording
from brake_hil.io.stamped_cdr import encode_stamped
from brake_hil.topics import MASTER_CYLINDER_PRESSURE, MEASURED_OUTPUTS, TopicSpec

T0 = 1_700_000_000_000_000_000
TOPICS = (MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS)
STEP = {spec.name: 1e-9 if spec.quantity == "x_c" else 1.0 for spec in TOPICS}
"""Value of sample k is k * STEP: 1 nm a sample keeps x_c within its physical bounds."""


def messages(spec: TopicSpec, count: int) -> list[bytes]:
    """``count`` CDR messages of a contract topic: value k * STEP, stamp T0 + k ms."""
    stamps = T0 + np.arange(count, dtype=np.int64) * 1_000_000
    values = np.arange(count, dtype=float) * STEP[spec.name]
    rows = encode_stamped(spec.msgtype, spec.field, stamps, values, "rig")
    return [row.tobytes() for row in rows]


def record(recorder: McapRecorder, count: int, start: int = 0) -> dict[str, list[bytes]]:
    """Write samples ``start .. count-1`` of every topic, logged 0.1 ms after their stamp."""
    data = {spec.name: messages(spec, count) for spec in TOPICS}
    handles = {
        spec.name: next(i for i, t in enumerate(recorder.topics) if t.name == spec.name)
        for spec in TOPICS
    }
    for k in range(start, count):
        for spec in TOPICS:
            recorder.write(handles[spec.name], T0 + k * 1_000_000 + 100_000, data[spec.name][k])
    return data


def new_recorder(path: Path, **options: object) -> McapRecorder:
    recorder = McapRecorder(path, **options)  # type: ignore[arg-type]
    for spec in TOPICS:
        recorder.add_topic(spec.name, spec.msgtype)
    return recorder


def listed_files(path: Path) -> list[str]:
    """The storage files ``metadata.yaml`` lists."""
    info = yaml.safe_load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    return list(info["relative_file_paths"])


def read_mcap_files(path: Path) -> dict[str, list[tuple[int, float]]]:
    """(log time, decoded value) per topic, by the independent reader over every listed file."""
    found: dict[str, list[tuple[int, float]]] = {}
    for name in listed_files(path):
        with (path / name).open("rb") as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            for _schema, channel, message, decoded in reader.iter_decoded_messages():
                spec = next(s for s in TOPICS if s.name == channel.topic)
                value = attrgetter(spec.field)(decoded)
                found.setdefault(channel.topic, []).append((message.log_time, value))
    return found


def test_messages_round_trip_byte_for_byte(tmp_path: Path) -> None:
    path = tmp_path / "bag"
    with new_recorder(path) as recorder:
        data = record(recorder, 500)
    with Reader(path) as reader:
        got: dict[str, list[bytes]] = {}
        for connection, log_time, raw in reader.messages():
            got.setdefault(connection.topic, []).append(raw)
            assert log_time % 1_000_000 == 100_000  # the log time given, not the stamp
        assert {t: i.msgcount for t, i in reader.topics.items()} == {s.name: 500 for s in TOPICS}
    assert got == data
    decoded = read_mcap_files(path)
    assert [v for _, v in decoded[MASTER_CYLINDER_PRESSURE.name]] == list(range(500))
    recording = read_recording(path, required=TOPICS)
    assert recording.start_stamp_ns == T0
    np.testing.assert_array_equal(recording.caliper_displacement, np.arange(500.0) * 1e-9)


def test_metadata_lists_qos_hash_and_schema_as_rosbag2_does(tmp_path: Path) -> None:
    path = tmp_path / "bag"
    with new_recorder(path) as recorder:
        record(recorder, 10)
    info = yaml.safe_load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 9
    assert info["storage_identifier"] == "mcap"
    assert info["relative_file_paths"] == ["bag_0.mcap"]
    topic = info["topics_with_message_count"][0]["topic_metadata"]
    assert topic["type_description_hash"].startswith("RIHS01_")
    with (path / "bag_0.mcap").open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
    assert all(
        {"offered_qos_profiles", "topic_type_hash"} <= set(c.metadata)
        for c in summary.channels.values()
    )


@pytest.mark.parametrize(
    "limits",
    [{"max_file_bytes": 40_000}, {"max_file_duration_s": 0.5}],
    ids=["by_size", "by_duration"],
)
def test_files_split_and_every_file_is_listed(tmp_path: Path, limits: dict[str, float]) -> None:
    path = tmp_path / "bag"
    with new_recorder(path, chunk_bytes=16_000, **limits) as recorder:
        record(recorder, 2000)
    info = yaml.safe_load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    files = info["relative_file_paths"]
    assert len(files) >= 3
    assert sorted(p.name for p in path.glob("*.mcap")) == sorted(files)
    assert sum(f["message_count"] for f in info["files"]) == 2000 * len(TOPICS)
    if "max_file_duration_s" in limits:
        assert all(f["duration"]["nanoseconds"] < 0.5e9 for f in info["files"])
    decoded = read_mcap_files(path)
    for spec in TOPICS:
        assert [v for _, v in decoded[spec.name]] == [k * STEP[spec.name] for k in range(2000)]
    recording = read_recording(path, required=TOPICS)
    assert recording.time.size == 2000


def test_a_killed_recording_keeps_every_committed_chunk(tmp_path: Path) -> None:
    path = tmp_path / "bag"
    recorder = new_recorder(path, chunk_bytes=20_000, max_file_bytes=60_000)
    record(recorder, 3000)
    killed = tmp_path / "killed"
    shutil.copytree(path, killed)  # the files as a kill -9 would leave them
    pending = recorder.message_count - sum(f.message_count for f in recorder.files())
    recorder.close()

    assert len(listed_files(killed)) >= 2
    with Reader(killed) as reader:  # rosbags: no summary in the open file, it scans
        counts = {t: i.msgcount for t, i in reader.topics.items()}
        read = sum(1 for _ in reader.messages())
    assert read == sum(counts.values()) == 3000 * len(TOPICS) - pending
    assert 0 < pending < 20_000 // 40  # only the chunk in memory is lost (~40+ bytes a message)
    decoded = read_mcap_files(killed)
    for spec in TOPICS:
        values = [v for _, v in decoded[spec.name]]
        step = STEP[spec.name]
        assert values == [k * step for k in range(len(values))]  # a gap-free prefix
    recording = read_recording(killed, required=TOPICS)
    assert recording.time.size >= 3000 - pending // len(TOPICS) - 1


def test_flush_bounds_what_a_kill_loses(tmp_path: Path) -> None:
    path = tmp_path / "bag"
    recorder = new_recorder(path)
    record(recorder, 100)
    recorder.flush()
    with Reader(path) as reader:
        assert reader.message_count == 100 * len(TOPICS)
    recorder.close()


def test_recover_metadata_counts_what_the_files_hold(tmp_path: Path) -> None:
    path = tmp_path / "bag"
    recorder = new_recorder(path, chunk_bytes=20_000, max_file_bytes=60_000)
    record(recorder, 1000)
    stale = (path / "metadata.yaml").read_text()
    record(recorder, 3000, start=1000)
    killed = tmp_path / "killed"
    shutil.copytree(path, killed)
    recorder.close()
    (killed / "metadata.yaml").write_text(stale)  # killed before the metadata caught up
    recover_metadata(killed)
    with Reader(killed) as reader:
        counts = {t: i.msgcount for t, i in reader.topics.items()}
        assert sum(counts.values()) == sum(1 for _ in reader.messages())
    assert sorted(listed_files(killed)) == sorted(p.name for p in killed.glob("*.mcap"))
    assert read_recording(killed, required=TOPICS).time.size > 2900


def test_an_existing_directory_and_an_unknown_type_are_refused(tmp_path: Path) -> None:
    with pytest.raises(FileExistsError, match="exists already"):
        McapRecorder(tmp_path)
    with McapRecorder(tmp_path / "bag") as recorder:
        with pytest.raises(ValueError, match="not in the typestore"):
            recorder.add_topic("/x", "no_pkgs/msg/Nothing")
        recorder.add_topic("/x", "std_msgs/msg/String")
        with pytest.raises(ValueError, match="registered already"):
            recorder.add_topic("/x", "std_msgs/msg/String")


def test_recorder_and_can_io_import_without_ros() -> None:
    code = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('rclpy', 'rosidl_runtime_py', 'rcl_interfaces'):\n"
        "            raise ImportError('ROS blocked for this test: ' + name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "import brake_hil.io.mcap_recorder, brake_hil.io.can_daq\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
