"""Bad recordings are refused with one line that names the file and the problem."""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader
import numpy as np
import pytest

from brake_hil.errors import MissingTopicError, RecordingError
from brake_hil.io.recording_reader import list_topics, read_recording
from brake_hil.io.recording_writer import (
    DEFAULT_START_STAMP_NS,
    TopicSeries,
    write_recording,
    write_topics,
)
from brake_hil.io.stamped_cdr import IntArray
from brake_hil.topics import (
    BLOCK_FORCE,
    BORE_PRESSURE,
    CALIPER_DISPLACEMENT,
    MASTER_CYLINDER_PRESSURE,
    TopicSpec,
)
from brake_hil.types import FloatArray

Run = tuple[FloatArray, dict[TopicSpec, FloatArray]]


def _refusal(path: Path, *fragments: str) -> RecordingError:
    """Read ``path``, expect a RecordingError naming it and every fragment, on one line."""
    with pytest.raises(RecordingError) as caught:
        read_recording(path)
    message = str(caught.value)
    assert message.startswith(str(path)), message
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, message
    return caught.value


def _stamps(time: FloatArray) -> IntArray:
    """Stamps (ns) of samples at ``time`` (s), as the writer makes them."""
    return DEFAULT_START_STAMP_NS + np.round(time * 1e9).astype(np.int64)


def test_a_missing_path_is_refused(tmp_path: Path) -> None:
    error = _refusal(tmp_path / "no_such_run", "no such file or directory")
    assert isinstance(error.__cause__, FileNotFoundError)


def test_a_directory_without_a_bag_is_refused(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("not a bag")
    _refusal(tmp_path, "not a rosbag2 directory", "metadata.yaml")


def test_a_directory_without_metadata_is_read_from_its_mcap_and_called_unfinished(
    tmp_path: Path, run: Run, caplog: pytest.LogCaptureFixture
) -> None:
    time, channels = run
    bag = write_recording(tmp_path / "run", time, channels)
    (bag / "metadata.yaml").unlink()  # what a kill -9 before the first metadata write leaves
    recording = read_recording(bag)
    assert recording.time.size == time.size
    (note,) = [r.getMessage() for r in caplog.records if r.name == "brake_hil.recording"]
    assert note.startswith(f"{bag}: unfinished recording (no metadata.yaml)")
    assert f"recovered {time.size * len(channels)} messages" in note


def test_a_file_that_is_not_a_recording_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "readme.txt"
    path.write_text("hello")
    _refusal(path, "not a recording")


def test_a_text_file_named_mcap_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "fake.mcap"
    path.write_text("hello, I am not an MCAP file")
    error = _refusal(path, "unreadable recording")
    assert error.__cause__ is not None


def _cut(tmp_path: Path, run: Run, inside_directory: bool, keep: int | None = None) -> Path:
    """The recording's MCAP cut to ``keep`` bytes (half when None); the path to read."""
    time, channels = run
    bag = write_recording(tmp_path / "run", time, channels)
    mcap = bag / "run_0.mcap"
    data = mcap.read_bytes()
    data = data[: len(data) // 2 if keep is None else keep]
    if inside_directory:
        mcap.write_bytes(data)
        return bag
    target = tmp_path / "cut.mcap"
    target.write_bytes(data)
    return target


@pytest.mark.parametrize("inside_directory", [False, True], ids=["bare", "in_bag"])
def test_an_mcap_cut_in_half_is_read_up_to_its_last_whole_chunk(
    tmp_path: Path, run: Run, inside_directory: bool, caplog: pytest.LogCaptureFixture
) -> None:
    time, channels = run
    target = _cut(tmp_path, run, inside_directory)
    recording = read_recording(target, required=tuple(channels))
    assert 0.2 * time.size < recording.time.size < 0.7 * time.size
    np.testing.assert_array_equal(recording.time, time[: recording.time.size])
    (note,) = [r.getMessage() for r in caplog.records if r.name == "brake_hil.recording"]
    assert note.startswith(f"{target}: unfinished recording")
    assert "the file ends inside a record at byte" in note


@pytest.mark.parametrize("inside_directory", [False, True], ids=["bare", "in_bag"])
def test_an_mcap_cut_before_its_first_whole_chunk_is_refused(
    tmp_path: Path, run: Run, inside_directory: bool
) -> None:
    target = _cut(tmp_path, run, inside_directory, keep=3000)
    _refusal(target, "unfinished recording", "truncated or corrupt", "not one whole chunk")


def test_a_corrupt_byte_inside_a_chunk_is_refused_not_read_as_data(
    tmp_path: Path, run: Run
) -> None:
    time, channels = run
    bag = write_recording(tmp_path / "run", time, channels)
    mcap = bag / "run_0.mcap"
    with mcap.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    chunk = summary.chunk_indexes[0]
    data = bytearray(mcap.read_bytes())
    data[chunk.chunk_start_offset + chunk.chunk_length // 2] ^= 0x10
    mcap.write_bytes(bytes(data))
    _refusal(bag, "truncated or corrupt")


def test_a_missing_storage_file_is_refused(tmp_path: Path, run: Run) -> None:
    time, channels = run
    bag = write_recording(tmp_path / "run", time, channels)
    (bag / "run_0.mcap").unlink()
    _refusal(bag, "run_0.mcap")


def test_a_missing_topic_is_refused_with_the_topics_that_are_there(
    tmp_path: Path, run: Run
) -> None:
    time, channels = run
    bag = write_recording(tmp_path / "run", time, {BORE_PRESSURE: channels[BORE_PRESSURE]})

    error = _refusal(bag, "missing topic /brake/master_cylinder/pressure", "/brake/bore/pressure")
    assert isinstance(error, MissingTopicError)
    with pytest.raises(MissingTopicError, match="/brake/block/force"):
        read_recording(
            write_recording(tmp_path / "other", time, {MASTER_CYLINDER_PRESSURE: time}),
            required=(MASTER_CYLINDER_PRESSURE, BLOCK_FORCE),
        )


def test_nan_samples_are_refused_naming_the_topic_count_and_first_index(
    tmp_path: Path, run: Run
) -> None:
    time, channels = run
    broken = dict(channels)
    broken[BORE_PRESSURE] = channels[BORE_PRESSURE].copy()
    broken[BORE_PRESSURE][[17, 18, 900]] = [np.nan, np.inf, np.nan]
    bag = write_recording(tmp_path / "run", time, broken)

    _refusal(bag, "/brake/bore/pressure", "3 NaN/inf samples", "sample 17")


def test_stamps_going_backwards_are_refused_naming_the_topic_and_sample(
    tmp_path: Path, run: Run
) -> None:
    """The clock of the rig jumps back while the logger's clock (log time) runs on."""
    time, channels = run
    log_times = _stamps(time)
    stamps = log_times.copy()
    stamps[1200:] -= 5_000_000  # 5 ms back at sample 1200
    bag = write_topics(
        tmp_path / "run",
        {
            MASTER_CYLINDER_PRESSURE: TopicSeries(
                stamps, channels[MASTER_CYLINDER_PRESSURE], log_times
            ),
        },
    )
    _refusal(bag, "/brake/master_cylinder/pressure", "go backwards", "sample 1200")


def test_repeated_stamps_are_refused(tmp_path: Path, run: Run) -> None:
    time, channels = run
    stamps = _stamps(time)
    stamps[10] = stamps[9]
    bag = write_topics(
        tmp_path / "run",
        {
            MASTER_CYLINDER_PRESSURE: TopicSeries(
                _stamps(time), channels[MASTER_CYLINDER_PRESSURE]
            ),
            CALIPER_DISPLACEMENT: TopicSeries(stamps, channels[CALIPER_DISPLACEMENT]),
        },
    )
    _refusal(bag, "/brake/caliper/displacement", "repeat", "sample 10")


def test_a_topic_with_fewer_than_two_samples_is_refused(tmp_path: Path, run: Run) -> None:
    time = run[0][:1]
    bag = write_recording(tmp_path / "run", time, {MASTER_CYLINDER_PRESSURE: time})
    _refusal(bag, "/brake/master_cylinder/pressure", "has 1 sample, at least 2")


def test_a_contract_topic_of_the_wrong_type_is_refused(tmp_path: Path, run: Run) -> None:
    time, channels = run
    mistyped = BORE_PRESSURE._replace(msgtype=BLOCK_FORCE.msgtype, field=BLOCK_FORCE.field)
    bag = write_recording(
        tmp_path / "run",
        time,
        {MASTER_CYLINDER_PRESSURE: channels[MASTER_CYLINDER_PRESSURE], mistyped: time},
    )
    _refusal(bag, "/brake/bore/pressure", "geometry_msgs/msg/WrenchStamped", "not sensor_msgs")


def test_a_channel_that_does_not_overlap_the_input_is_refused(tmp_path: Path, run: Run) -> None:
    time, channels = run
    stamps = _stamps(time)
    bag = write_topics(
        tmp_path / "run",
        {
            MASTER_CYLINDER_PRESSURE: TopicSeries(stamps, channels[MASTER_CYLINDER_PRESSURE]),
            BLOCK_FORCE: TopicSeries(stamps + 10_000_000_000, channels[BLOCK_FORCE]),
        },
    )
    _refusal(bag, "/brake/block/force", "does not overlap")


def test_list_topics_refuses_a_missing_path_too(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match="no_such_bag: no such file or directory"):
        list_topics(tmp_path / "no_such_bag")


def test_the_writer_refuses_backward_stamps_without_log_times(tmp_path: Path, run: Run) -> None:
    """Stored in log-time order, such samples would read back sorted, hiding the jump."""
    time, channels = run
    stamps = _stamps(time)
    stamps[500], stamps[501] = stamps[501], stamps[500]
    with pytest.raises(ValueError, match="sample 501.*log_times_ns"):
        write_topics(
            tmp_path / "run",
            {MASTER_CYLINDER_PRESSURE: TopicSeries(stamps, channels[MASTER_CYLINDER_PRESSURE])},
        )
    assert not (tmp_path / "run").exists()
