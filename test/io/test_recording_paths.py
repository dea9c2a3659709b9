"""A recording's path: a typo named as such, with the closest name beside it."""

from __future__ import annotations

from pathlib import Path

import pytest

from brake_hil.errors import RecordingError
from brake_hil.io.recording_paths import existing_recording


def test_a_typo_is_no_such_recording_and_the_closest_name_is_offered(tmp_path: Path) -> None:
    (tmp_path / "effect_hose_compliance").mkdir()
    (tmp_path / "effect_hose_compliance.rig.yaml").write_text("rig: {}\n")
    (tmp_path / "one_washer_open").mkdir()
    with pytest.raises(RecordingError) as raised:
        existing_recording(tmp_path / "hose_compliance")
    assert str(raised.value) == (
        f"{tmp_path / 'hose_compliance'}: no such recording; did you mean "
        f"{tmp_path / 'effect_hose_compliance'}?"
    )
    with pytest.raises(RecordingError) as far:
        existing_recording(tmp_path / "zzz")
    assert str(far.value) == f"{tmp_path / 'zzz'}: no such recording"
    assert existing_recording(tmp_path / "one_washer_open") == tmp_path / "one_washer_open"
