"""A recording known by its content, a rig file by its bytes, its span read cheaply."""

from __future__ import annotations

from pathlib import Path
import shutil

import pytest

from brake_hil.errors import RecordingError, RigError
from brake_hil.io.recording_reader import read_recording
from brake_hil.results import identity as identity_module
from brake_hil.results.identity import identify, identify_loosely, recording_hash, rig_hash
from test.conftest import PROJECT

BAG = PROJECT / "bags" / "one_washer_open"
RIG = PROJECT / "bags" / "one_washer_open.rig.yaml"


@pytest.fixture(scope="module")
def renamed_copy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The bundled bag copied under another name, its metadata.yaml edited."""
    copy = tmp_path_factory.mktemp("bags") / "renamed"
    shutil.copytree(BAG, copy)
    metadata = copy / "metadata.yaml"
    metadata.write_text(metadata.read_text() + "\n# re-indexed\n")
    return copy


def test_the_same_bytes_are_the_same_recording_wherever_they_lie(renamed_copy: Path) -> None:
    first = identify(BAG, RIG)
    assert identify(BAG, RIG) == first
    copied = identify(renamed_copy, RIG)
    assert copied.content_hash == first.content_hash
    assert copied.path != first.path
    assert len(first.content_hash) == 64


def test_one_byte_changed_is_a_new_recording(renamed_copy: Path, tmp_path: Path) -> None:
    changed = tmp_path / "changed"
    shutil.copytree(renamed_copy, changed)
    storage = next(changed.glob("*.mcap"))
    data = bytearray(storage.read_bytes())
    data[len(data) // 2] ^= 0xFF
    storage.write_bytes(bytes(data))
    assert recording_hash(changed) != recording_hash(BAG)


def test_the_rig_file_is_known_by_its_values_and_named_by_its_name(tmp_path: Path) -> None:
    found = identify(BAG, RIG)
    assert found.rig_name == "nominal one-washer rig"
    assert found.rig_hash == rig_hash(RIG)
    commented = tmp_path / "commented.rig.yaml"
    commented.write_text("# copied beside another recording\n" + RIG.read_text() + "\n\n")
    assert identify(BAG, commented).rig_hash == found.rig_hash
    edited = tmp_path / "edited.rig.yaml"
    text = RIG.read_text()
    assert "excitation_hz: 5.0" in text
    edited.write_text(text.replace("excitation_hz: 5.0", "excitation_hz: 5.5"))
    assert identify(BAG, edited).rig_hash != found.rig_hash


def test_the_span_from_the_mcap_summary_matches_the_readers(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    found = identify(BAG, RIG)
    assert found.duration_s == pytest.approx(18.0, abs=0.1)
    monkeypatch.setattr(identity_module, "_summary_span", lambda files: None)
    read = identify(BAG, RIG)  # through the recording reader (an sqlite3 bag, unfinished)
    assert read.start_ns == read_recording(BAG).start_stamp_ns
    assert read.start_ns == pytest.approx(found.start_ns, abs=1e7)
    assert read.end_ns == pytest.approx(found.end_ns, abs=1e7)


def test_a_missing_recording_or_bad_rig_is_refused_naming_it(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match=f"^{tmp_path / 'gone'}: no such"):
        identify(tmp_path / "gone", RIG)
    bad = tmp_path / "bad.yaml"
    bad.write_text("rig: {name: 3}\n")
    with pytest.raises(RigError, match=str(bad)):
        identify(BAG, bad)


def test_a_failed_recording_is_still_identified_loosely(tmp_path: Path) -> None:
    loose = identify_loosely(tmp_path / "gone", tmp_path / "gone.rig.yaml")
    assert loose.content_hash.startswith("path:")
    assert loose.rig_hash.startswith("path:")
    assert (loose.rig_name, loose.start_ns, loose.duration_s) == ("gone", None, None)
    assert identify_loosely(BAG, RIG).content_hash == recording_hash(BAG)
