"""The reader on unfinished rosbag2 MCAP directories: stale or missing ``metadata.yaml``.

The recordings are the streaming recorder's files copied while it is open (what ``kill -9``
leaves, see ``test_mcap_recorder``), split into several files, the last one unfinished.
"""

from __future__ import annotations

from pathlib import Path
import shutil

import pytest
import yaml

from brake_hil.io.recording_reader import list_topics, read_recording
from brake_hil.io.unfinished import unfinished_reason
from test.io.test_mcap_recorder import TOPICS, new_recorder, record


def notes(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "brake_hil.recording"]


@pytest.fixture
def split_bags(tmp_path: Path) -> tuple[Path, Path, str]:
    """(killed copy, finished recording, the killed copy's metadata.yaml one chunk earlier)."""
    finished = tmp_path / "bag"
    recorder = new_recorder(finished, chunk_bytes=20_000, max_file_bytes=60_000)
    record(recorder, 2000)
    stale = (finished / "metadata.yaml").read_text()
    record(recorder, 3000, start=2000)
    killed = tmp_path / "killed"
    shutil.copytree(finished, killed)
    recorder.close()
    return killed, finished, stale


def test_a_finished_recording_reads_without_a_note(
    split_bags: tuple[Path, Path, str], caplog: pytest.LogCaptureFixture
) -> None:
    _, finished, _ = split_bags
    assert unfinished_reason(finished) is None
    assert read_recording(finished, required=TOPICS).time.size == 3000
    assert notes(caplog) == []


def test_stale_metadata_is_not_trusted_the_files_are_read(
    split_bags: tuple[Path, Path, str], caplog: pytest.LogCaptureFixture
) -> None:
    killed, _, stale = split_bags
    expected = read_recording(killed, required=TOPICS).time.size  # metadata caught up
    assert expected > 2900
    (killed / "metadata.yaml").write_text(stale)  # killed before the metadata caught up
    reason = unfinished_reason(killed)
    assert reason is not None and "does not list" in reason
    caplog.clear()
    assert read_recording(killed, required=TOPICS).time.size == expected
    (note,) = notes(caplog)
    assert note.startswith(f"{killed}: unfinished recording (metadata.yaml does not list")


def test_metadata_counting_other_messages_than_finished_files_is_caught(
    split_bags: tuple[Path, Path, str], caplog: pytest.LogCaptureFixture
) -> None:
    _, finished, _ = split_bags
    info = yaml.safe_load((finished / "metadata.yaml").read_text())
    info["rosbag2_bagfile_information"]["topics_with_message_count"][0]["message_count"] -= 5
    (finished / "metadata.yaml").write_text(yaml.safe_dump(info))
    assert "metadata.yaml counts" in str(unfinished_reason(finished))
    assert read_recording(finished, required=TOPICS).time.size == 3000
    assert len(notes(caplog)) == 1


def test_list_topics_counts_what_was_recovered(
    split_bags: tuple[Path, Path, str], caplog: pytest.LogCaptureFixture
) -> None:
    killed, _, _ = split_bags
    (killed / "metadata.yaml").unlink()
    topics = {t.name: t for t in list_topics(killed)}
    assert set(topics) == {s.name for s in TOPICS}
    assert all(2900 < t.message_count <= 3000 for t in topics.values())
    assert "no metadata.yaml" in notes(caplog)[0]
