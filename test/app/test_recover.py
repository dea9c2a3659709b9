"""``run_recover``: a finished copy of an unfinished recording that independent readers open.

The unfinished recordings are what a killed writer leaves: the streaming recorder's files
copied while it is still open (it buffers nothing outside its pending chunk, so that is what
``kill -9`` leaves), then the last file cut inside a record, ``metadata.yaml`` stale or
removed. The copies are read back with python ``mcap``'s seeking reader (summary, chunk
indexes, statistics) and with ``rosbags`` (``Reader`` and ``AnyReader``).
"""

from __future__ import annotations

import hashlib
from pathlib import Path
import shutil

from mcap.reader import make_reader
import pytest
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import Reader
import yaml

from brake_hil.app.recover import run_recover
from brake_hil.errors import RecordingError
from brake_hil.io.mcap_salvage import is_finished, salvage_file
from brake_hil.io.recording_reader import read_recording
from test.io.test_mcap_recorder import TOPICS, new_recorder, record

COUNT = 3000


def killed_split_recording(tmp_path: Path, cut_bytes: int = 0) -> tuple[Path, Path]:
    """A split recording as ``kill -9`` leaves it (last file cut by ``cut_bytes``).

    Returns the killed copy and the recording finished normally (the reference).
    """
    reference = tmp_path / "bag"
    recorder = new_recorder(reference, chunk_bytes=20_000, max_file_bytes=60_000)
    record(recorder, COUNT)
    killed = tmp_path / "killed"
    shutil.copytree(reference, killed)
    recorder.close()
    last = sorted(killed.glob("*.mcap"), key=lambda p: int(p.stem.rsplit("_", 1)[1]))[-1]
    if cut_bytes:
        data = last.read_bytes()
        last.write_bytes(data[: len(data) - cut_bytes])
    return killed, reference


def messages_by_seeking_reader(bag: Path) -> dict[str, list[tuple[int, bytes]]]:
    """(log time, bytes) per topic from every listed file, each read through its summary."""
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    found: dict[str, list[tuple[int, bytes]]] = {}
    for name in info["relative_file_paths"]:
        with (bag / name).open("rb") as stream:
            reader = make_reader(stream)
            summary = reader.get_summary()
            assert summary is not None and summary.statistics is not None
            assert summary.chunk_indexes  # the seeking reader finds the chunks by index
            for _schema, channel, message in reader.iter_messages():
                found.setdefault(channel.topic, []).append((message.log_time, message.data))
            assert sum(len(v) for v in found.values()) >= summary.statistics.message_count
    return found


def input_digest(bag: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(bag.iterdir())}


def test_a_killed_split_recording_with_a_cut_last_file_is_copied_finished(
    tmp_path: Path,
) -> None:
    killed, reference = killed_split_recording(tmp_path, cut_bytes=300)
    before = input_digest(killed)
    salvaged = [salvage_file(p) for p in sorted(killed.glob("*.mcap"))]
    assert not is_finished(sorted(killed.glob("*.mcap"))[-1])
    result = run_recover(killed, tmp_path / "out")
    assert input_digest(killed) == before  # the input is never written to
    assert result.reason is not None and "not finished" in result.reason
    assert len(result.files) == len(salvaged) >= 4
    assert result.message_count == sum(len(s.messages) for s in salvaged)
    assert result.files[-1].lost_bytes > 0 and not result.files[-1].finished

    out = tmp_path / "out"
    assert all(is_finished(p) for p in out.glob("*.mcap"))
    # python mcap's seeking reader: the messages, byte for byte, with their log times
    copied = messages_by_seeking_reader(out)
    original = messages_by_seeking_reader(reference)
    for spec in TOPICS:
        got = copied[spec.name]
        assert got == original[spec.name][: len(got)]  # a gap-free prefix of each topic
        assert len(got) > COUNT - 200  # all but the chunk in memory and the cut one
    # rosbags: metadata.yaml matches the files
    info = yaml.safe_load((out / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    with Reader(out) as reader:
        counts = {t: i.msgcount for t, i in reader.topics.items()}
        times = [t for _, t, _ in reader.messages()]
        assert counts == {t: len(v) for t, v in copied.items()}
        assert len(times) == reader.message_count == info["message_count"]
        assert reader.start_time == min(times) == info["starting_time"]["nanoseconds_since_epoch"]
        assert reader.end_time == max(times) + 1
        assert info["duration"]["nanoseconds"] == max(times) - min(times)
        assert {c.msgtype for c in reader.connections} == {s.msgtype for s in TOPICS}
    assert [f["message_count"] for f in info["files"]] == [f.messages for f in result.files]
    with Reader(reference) as original_reader:
        offered = {c.topic: c.ext.offered_qos_profiles for c in original_reader.connections}
        hashes = {c.topic: c.digest for c in original_reader.connections}
    with Reader(out) as reader:
        assert {c.topic: c.ext.offered_qos_profiles for c in reader.connections} == offered
        assert {c.topic: c.digest for c in reader.connections} == hashes
    with AnyReader([out]) as any_reader:
        decoded = [
            any_reader.deserialize(raw, conn.msgtype)
            for conn, _, raw in any_reader.messages()
            if conn.topic == TOPICS[0].name
        ]
    assert [m.fluid_pressure for m in decoded] == [float(k) for k in range(len(decoded))]
    assert read_recording(out, required=TOPICS).time.size > COUNT - 200


def test_metadata_missing_or_stale_is_rebuilt_from_the_files(tmp_path: Path) -> None:
    killed, _ = killed_split_recording(tmp_path)
    stale = tmp_path / "stale"
    shutil.copytree(killed, stale)
    info = yaml.safe_load((stale / "metadata.yaml").read_text())
    info["rosbag2_bagfile_information"]["relative_file_paths"].pop()  # one file unlisted
    info["rosbag2_bagfile_information"]["message_count"] = 7
    (stale / "metadata.yaml").write_text(yaml.safe_dump(info))
    gone = tmp_path / "gone"
    shutil.copytree(killed, gone)
    (gone / "bag_1.mcap").unlink()
    (killed / "metadata.yaml").unlink()
    result = run_recover(gone)
    assert result.reason == "metadata.yaml lists bag_1.mcap, not on disk"
    assert len(result.files) == len(list(gone.glob("*.mcap")))
    for bag in (killed, stale):
        result = run_recover(bag)
        assert result.output == tmp_path / f"{bag.name}_recovered"
        with Reader(result.output) as reader:
            assert (
                reader.message_count == result.message_count == sum(1 for _ in reader.messages())
            )
        assert len(result.files) == len(list(bag.glob("*.mcap")))
        assert result.message_count > (COUNT - 100) * len(TOPICS)


def test_a_bare_cut_mcap_becomes_a_rosbag2_directory(tmp_path: Path) -> None:
    killed, _ = killed_split_recording(tmp_path)
    bare = tmp_path / "run.mcap"
    data = (killed / "bag_0.mcap").read_bytes()
    bare.write_bytes(data[: len(data) * 2 // 3])
    result = run_recover(bare)
    assert result.output == tmp_path / "run_recovered"
    with Reader(result.output) as reader:
        assert 0 < reader.message_count == result.message_count


def test_existing_output_no_mcap_and_nothing_whole_are_refused(tmp_path: Path) -> None:
    killed, _ = killed_split_recording(tmp_path)
    with pytest.raises(RecordingError, match="exists already"):
        run_recover(killed, killed)
    with pytest.raises(RecordingError, match="inside the input"):
        run_recover(killed, killed / "copy")
    (tmp_path / "empty").mkdir()
    with pytest.raises(RecordingError, match="no .mcap file"):
        run_recover(tmp_path / "empty")
    header_only = tmp_path / "header.mcap"
    header_only.write_bytes((killed / "bag_0.mcap").read_bytes()[:300])
    with pytest.raises(RecordingError, match="not one whole chunk"):
        run_recover(header_only)
    assert not (tmp_path / "header_recovered").exists()
