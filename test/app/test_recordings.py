"""Which recordings a many-recording command means, and where each one's outputs go."""

from __future__ import annotations

from pathlib import Path

import pytest

from brake_hil.app.recordings import (
    find_recordings,
    is_recording,
    mirrored_folder,
    names_many,
)
from brake_hil.errors import BrakeHilError


def _bag(path: Path) -> Path:
    path.mkdir(parents=True)
    (path / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    (path / f"{path.name}_0.mcap").write_bytes(b"\x89MCAP0\r\n")
    return path


@pytest.fixture
def lab(tmp_path: Path) -> Path:
    """lab/rig-1/run-01..02, lab/rig-2/run-01 (bag folders), lab/loose/a.mcap (a folder of
    MCAP files without metadata.yaml: a recording too), a link looping back to lab."""
    for rig, runs in (("rig-1", 2), ("rig-2", 1)):
        for run in range(1, runs + 1):
            _bag(tmp_path / "lab" / rig / f"run-{run:02d}")
    (tmp_path / "lab" / "loose").mkdir()
    (tmp_path / "lab" / "loose" / "a.mcap").write_bytes(b"\x89MCAP0\r\n")
    (tmp_path / "lab" / "notes.txt").write_text("not a recording")
    (tmp_path / "lab" / "loop").symlink_to(tmp_path / "lab")
    return tmp_path / "lab"


def test_a_folder_of_recordings_is_searched_without_following_links(lab: Path) -> None:
    found = find_recordings([lab])
    assert [str(p.relative_to(lab)) for p in found] == [
        "loose",
        "rig-1/run-01",
        "rig-1/run-02",
        "rig-2/run-01",
    ]
    assert all(is_recording(p) for p in found)


def test_globs_and_repeated_paths_give_each_recording_once(lab: Path) -> None:
    found = find_recordings([f"{lab}/rig-*/run-01", lab / "rig-1" / "run-01"])
    assert found == [lab / "rig-1" / "run-01", lab / "rig-2" / "run-01"]
    assert find_recordings([f"{lab}/**/*.mcap"]) == [
        lab / "loose" / "a.mcap",
        lab / "rig-1" / "run-01" / "run-01_0.mcap",
        lab / "rig-1" / "run-02" / "run-02_0.mcap",
        lab / "rig-2" / "run-01" / "run-01_0.mcap",
    ]


@pytest.mark.parametrize(
    ("pattern", "message"),
    [
        ("missing", "no such file or folder"),
        ("rig-9*/x", "no recording matches this pattern"),
        ("empty", "no recording in this folder"),
        ("notes.txt", "not a recording"),
    ],
)
def test_a_pattern_that_names_no_recording_is_refused_naming_it(
    lab: Path, pattern: str, message: str
) -> None:
    (lab / "empty").mkdir()
    with pytest.raises(BrakeHilError, match=message) as caught:
        find_recordings([lab / "rig-1", f"{lab}/{pattern}"])
    assert pattern in str(caught.value)


def test_one_recording_is_one_and_folders_globs_or_several_are_many(lab: Path) -> None:
    run = lab / "rig-1" / "run-01"
    assert not names_many([run])
    assert not names_many([lab / "missing"])  # refused as one recording: its file named
    assert names_many([lab])
    assert names_many([f"{lab}/rig-*/run-01"])
    assert names_many([run, lab / "rig-2" / "run-01"])


def test_each_recording_gets_its_own_folder_mirroring_the_tree(lab: Path, tmp_path: Path) -> None:
    found = find_recordings([lab])
    folders = [mirrored_folder(r, found, tmp_path / "out") for r in found]
    assert [str(f.relative_to(tmp_path / "out")) for f in folders] == [
        "loose",
        "rig-1/run-01",
        "rig-1/run-02",
        "rig-2/run-01",
    ]
    same_name = [_bag(tmp_path / "x" / "run"), tmp_path / "x" / "run.mcap"]
    same_name[1].write_bytes(b"\x89MCAP0\r\n")
    mirrored = {mirrored_folder(r, same_name, tmp_path / "o") for r in same_name}
    assert len(mirrored) == 2
