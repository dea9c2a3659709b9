"""Recordings written by brake_hil read back intact, by independent readers and by our own."""

from __future__ import annotations

from pathlib import Path
import shutil

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from mcap_ros2.writer import Writer as McapRos2Writer
import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
import yaml

from brake_hil.io.recording_reader import list_topics, read_recording
from brake_hil.io.recording_writer import (
    DEFAULT_FRAME_ID,
    DEFAULT_START_STAMP_NS,
    TopicSeries,
    save_recording,
    write_recording,
    write_topics,
)
from brake_hil.io.stamped_cdr import decode_stamped, encode_stamped
from brake_hil.topics import (
    AIR_PRESSURE,
    BLOCK_FORCE,
    BORE_PRESSURE,
    CALIPER_DISPLACEMENT,
    MASTER_CYLINDER_PRESSURE,
    TopicSpec,
)
from brake_hil.types import FloatArray

Run = tuple[FloatArray, dict[TopicSpec, FloatArray]]


def _field(message: object, dotted: str) -> float:
    for part in dotted.split("."):
        message = getattr(message, part)
    assert isinstance(message, float)
    return message


def _only_mcap(bag: Path) -> Path:
    (mcap,) = bag.glob("*.mcap")
    return mcap


def test_written_recording_reads_back_intact_with_the_mcap_package(
    tmp_path: Path, run: Run
) -> None:
    time, channels = run
    bag = write_recording(tmp_path / "run", time, channels)
    stamps = DEFAULT_START_STAMP_NS + np.round(time * 1e9).astype(np.int64)

    received: dict[str, list[tuple[int, int, float, str]]] = {}
    with _only_mcap(bag).open("rb") as stream:
        reader = make_reader(stream, validate_crcs=True, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary is not None
        schemas = {s.name: s.encoding for s in summary.schemas.values()}
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            assert schema is not None and channel.message_encoding == "cdr"
            spec = next(s for s in channels if s.name == channel.topic)
            stamp = decoded.header.stamp.sec * 1_000_000_000 + decoded.header.stamp.nanosec
            assert message.log_time == stamp
            value = _field(decoded, spec.field)
            received.setdefault(channel.topic, []).append(
                (message.log_time, stamp, value, decoded.header.frame_id)
            )

    assert schemas == {spec.msgtype: "ros2msg" for spec in channels}
    for spec, values in channels.items():
        rows = received[spec.name]
        assert [r[1] for r in rows] == stamps.tolist()
        assert np.array_equal([r[2] for r in rows], values)
        assert {r[3] for r in rows} == {DEFAULT_FRAME_ID}

    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert metadata["storage_identifier"] == "mcap"
    assert metadata["relative_file_paths"] == [_only_mcap(bag).name]
    assert metadata["message_count"] == len(channels) * time.size
    counts = {
        t["topic_metadata"]["name"]: t["message_count"]
        for t in metadata["topics_with_message_count"]
    }
    assert counts == {spec.name: time.size for spec in channels}


def test_written_recording_reads_back_equal_with_read_recording(tmp_path: Path, run: Run) -> None:
    time, channels = run
    bag = write_recording(tmp_path / "run", time, channels, start_stamp_ns=1_234_567_890_123)

    recording = read_recording(bag)

    assert recording.path == bag
    assert recording.start_stamp_ns == 1_234_567_890_123
    assert np.array_equal(recording.time, time)
    assert recording.sample_rate == pytest.approx(1000.0)
    assert recording.topics == tuple(sorted(spec.name for spec in channels))
    assert np.array_equal(recording.master_cylinder_pressure, channels[MASTER_CYLINDER_PRESSURE])
    assert recording.bore_pressure is not None and recording.block_force is not None
    assert np.array_equal(recording.bore_pressure, channels[BORE_PRESSURE])
    assert np.array_equal(recording.block_force, channels[BLOCK_FORCE])
    measured = recording.measured()["x_c"]
    assert measured is not None and np.array_equal(measured, channels[CALIPER_DISPLACEMENT])
    assert recording.predicted_bore_pressure is not None
    assert recording.air_pressure is None


def test_bare_mcap_copied_out_of_its_directory_reads_the_same(tmp_path: Path, run: Run) -> None:
    time, channels = run
    bag = write_recording(tmp_path / "run", time, channels)
    bare = tmp_path / "elsewhere" / "copy.mcap"
    bare.parent.mkdir()
    shutil.copyfile(_only_mcap(bag), bare)

    from_dir, from_file = read_recording(bag), read_recording(bare)

    assert from_file.path == bare
    assert from_file.topics == from_dir.topics
    assert from_file.start_stamp_ns == from_dir.start_stamp_ns
    assert np.array_equal(from_file.time, from_dir.time)
    assert from_file.block_force is not None and from_dir.block_force is not None
    assert np.array_equal(from_file.block_force, from_dir.block_force)
    assert list_topics(bare) == list_topics(bag)


def test_saved_recording_reads_back_as_the_same_recording(tmp_path: Path, run: Run) -> None:
    time, channels = run
    original = read_recording(write_recording(tmp_path / "first", time, channels))

    copy = read_recording(save_recording(tmp_path / "second", original))

    assert copy.start_stamp_ns == original.start_stamp_ns
    assert np.array_equal(copy.time, original.time)
    for name in ("master_cylinder_pressure", "bore_pressure", "predicted_caliper_displacement"):
        assert np.array_equal(getattr(copy, name), getattr(original, name))


def test_writer_refuses_to_overwrite_an_existing_directory(tmp_path: Path, run: Run) -> None:
    time, channels = run
    bag = write_recording(tmp_path / "run", time, channels)
    before = sorted((p.name, p.stat().st_size) for p in bag.iterdir())

    with pytest.raises(FileExistsError, match="run"):
        write_recording(bag, time, channels)
    assert sorted((p.name, p.stat().st_size) for p in bag.iterdir()) == before


def test_writer_refuses_a_channel_shorter_than_time(tmp_path: Path, run: Run) -> None:
    time, channels = run
    with pytest.raises(ValueError, match="/brake/bore/pressure"):
        write_recording(tmp_path / "run", time, {BORE_PRESSURE: channels[BORE_PRESSURE][:-1]})
    assert not (tmp_path / "run").exists()


def test_mcap_from_another_writer_with_other_frame_ids_and_skewed_stamps_reads(
    tmp_path: Path,
) -> None:
    """A bare MCAP by mcap_ros2 (zstd chunks): channels on stamps 0.4 ms after p_i's."""
    store = get_typestore(Stores.ROS2_KILTED)
    n, start = 2000, 1_650_000_000_000_000_000
    p_i_stamps = start + np.arange(n, dtype=np.int64) * 1_000_000
    p_b_stamps = p_i_stamps + 400_000
    p_i = (1.0 + np.sin(np.arange(n) / 50.0)) * 1e6  # gauge pressures: within physical bounds
    p_b = (1.0 + np.cos(np.arange(n) / 50.0)) * 1e6
    path = tmp_path / "simulator.mcap"
    with path.open("wb") as stream:
        writer = McapRos2Writer(stream)
        for spec, stamps, values, frame in (
            (MASTER_CYLINDER_PRESSURE, p_i_stamps, p_i, ""),
            (BORE_PRESSURE, p_b_stamps, p_b, "a_much_longer_frame_id"),
        ):
            msgdef, _ = store.generate_msgdef(spec.msgtype, ros_version=2)
            schema = writer.register_msgdef(spec.msgtype, msgdef)
            for stamp, value in zip(stamps.tolist(), values.tolist()):
                sec, nanosec = divmod(stamp, 1_000_000_000)
                message = {
                    "header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": frame},
                    "fluid_pressure": value,
                    "variance": 0.0,
                }
                writer.write_message(spec.name, schema, message, log_time=stamp + 123)
        writer.finish()  # type: ignore[no-untyped-call]

    recording = read_recording(path)

    # p_b starts 0.4 ms late: the recording is cut to the common span, p_i's first sample goes
    assert recording.start_stamp_ns == p_i_stamps[1]
    assert np.array_equal(recording.master_cylinder_pressure, p_i[1:])
    expected = np.interp(p_i_stamps[1:] - start, p_b_stamps - start, p_b)
    assert recording.bore_pressure is not None
    np.testing.assert_allclose(recording.bore_pressure, expected, rtol=0, atol=1e-6)


def test_unrelated_topics_of_unknown_types_do_not_stop_reading(tmp_path: Path, run: Run) -> None:
    """Service events and types no typestore knows are listed, never deserialised."""
    time, channels = run
    store = get_typestore(Stores.ROS2_KILTED)
    stamps = DEFAULT_START_STAMP_NS + np.round(time * 1e9).astype(np.int64)
    bag = tmp_path / "with_services"
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        event = writer.add_connection(
            "/test_service1/_service_event",
            "test_msgs/srv/BasicTypes_Event",
            msgdef="uint8 this_is_not_the_real_definition\n",
            rihs01="RIHS01_" + "0" * 64,
        )
        p_i = writer.add_connection(
            MASTER_CYLINDER_PRESSURE.name, MASTER_CYLINDER_PRESSURE.msgtype, typestore=store
        )
        rows = encode_stamped(
            MASTER_CYLINDER_PRESSURE.msgtype,
            MASTER_CYLINDER_PRESSURE.field,
            stamps,
            channels[MASTER_CYLINDER_PRESSURE],
            "caliper",
        )
        for index, stamp in enumerate(stamps.tolist()):
            writer.write(p_i, stamp, rows[index].tobytes())
            if index % 500 == 0:
                writer.write(event, stamp, b"\x00\x01\x00\x00garbage")

    recording = read_recording(bag)

    assert "/test_service1/_service_event" in recording.topics
    assert np.array_equal(recording.master_cylinder_pressure, channels[MASTER_CYLINDER_PRESSURE])


def test_sqlite3_bag_with_brake_topics_reads(tmp_path: Path, run: Run) -> None:
    time, channels = run
    store = get_typestore(Stores.ROS2_KILTED)
    stamps = DEFAULT_START_STAMP_NS + np.round(time * 1e9).astype(np.int64)
    bag = tmp_path / "sqlite"
    with Writer(bag, version=8, storage_plugin=StoragePlugin.SQLITE3) as writer:
        for spec in (MASTER_CYLINDER_PRESSURE, BLOCK_FORCE):
            connection = writer.add_connection(spec.name, spec.msgtype, typestore=store)
            rows = encode_stamped(spec.msgtype, spec.field, stamps, channels[spec], "rig")
            for index, stamp in enumerate(stamps.tolist()):
                writer.write(connection, stamp, rows[index].tobytes())

    recording = read_recording(bag, required=(MASTER_CYLINDER_PRESSURE, BLOCK_FORCE))

    assert recording.block_force is not None
    assert np.array_equal(recording.block_force, channels[BLOCK_FORCE])
    assert recording.bore_pressure is None


@pytest.mark.parametrize("frame_id", ["", "rig", "caliper", "a_much_longer_frame_id"])
@pytest.mark.parametrize(
    "spec", [MASTER_CYLINDER_PRESSURE, BLOCK_FORCE, CALIPER_DISPLACEMENT], ids=lambda s: s.msgtype
)
def test_stamped_cdr_matches_the_rosbags_serialiser(spec: TopicSpec, frame_id: str) -> None:
    store = get_typestore(Stores.ROS2_KILTED)
    stamps = np.array([-1_500_000_000, 0, 1_700_000_000_123_456_789], dtype=np.int64)
    values = np.array([-1.5, 0.0, 2.5e6])

    rows = encode_stamped(spec.msgtype, spec.field, stamps, values, frame_id)

    for row, stamp, value in zip(rows, stamps.tolist(), values.tolist()):
        message = store.deserialize_cdr(row.tobytes(), spec.msgtype)
        assert _field(message, spec.field) == value
        header = message.header  # type: ignore[attr-defined]
        assert header.stamp.sec * 1_000_000_000 + header.stamp.nanosec == stamp
        assert header.frame_id == frame_id
        assert bytes(store.serialize_cdr(message, spec.msgtype)) == row.tobytes()
    big_endian = [
        bytes(
            store.serialize_cdr(
                store.deserialize_cdr(r.tobytes(), spec.msgtype), spec.msgtype, little_endian=False
            )
        )
        for r in rows
    ]
    decoded_stamps, decoded_values = decode_stamped(spec.msgtype, spec.field, big_endian)
    assert np.array_equal(decoded_stamps, stamps)
    assert np.array_equal(decoded_values, values)


def test_an_18_s_1_khz_recording_of_seven_topics_writes_and_reads_whole(
    tmp_path: Path, long_run: Run
) -> None:
    # its speed is benchmarks/bench_io.py's (against a copy of the same files)
    time, channels = long_run
    bag = write_recording(tmp_path / "long", time, channels)
    recording = read_recording(bag)

    assert recording.time.size == 18_000


def test_an_optional_topic_without_messages_counts_as_absent(tmp_path: Path, run: Run) -> None:
    time, channels = run
    stamps = DEFAULT_START_STAMP_NS + np.round(time * 1e9).astype(np.int64)
    bag = write_topics(
        tmp_path / "with_empty_topic",
        {
            MASTER_CYLINDER_PRESSURE: TopicSeries(stamps, channels[MASTER_CYLINDER_PRESSURE]),
            AIR_PRESSURE: TopicSeries(np.zeros(0, dtype=np.int64), np.zeros(0)),
        },
    )

    recording = read_recording(bag)

    assert AIR_PRESSURE.name in recording.topics
    assert recording.air_pressure is None
