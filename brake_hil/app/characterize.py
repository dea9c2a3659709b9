"""``brake-hil characterize``: the paper's Table 3 (and Table 1) per steady segment."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from brake_hil.analysis.characterization import SegmentCharacterization, characterize
from brake_hil.app.naming import naming
from brake_hil.app.output import check_outputs, write_json
from brake_hil.io.opened import open_recording
from brake_hil.physics.rig import Rig

__all__ = ["CharacterizeResult", "run_characterize"]


@dataclass(frozen=True)
class CharacterizeResult:
    """Each steady segment's characterisation and the file it was written to."""

    recording_path: Path
    rig_path: Path
    rig: Rig
    segments: tuple[SegmentCharacterization, ...]
    document: dict[str, object]  # what the JSON file holds
    json_path: Path | None


def run_characterize(
    recording_path: Path, rig_path: Path, json_path: Path | None = None
) -> CharacterizeResult:
    """Characterise every steady segment of the recording (seed Table 3).

    Args:
        recording_path: a recording with ``p_i`` and the three measured outputs.
        rig_path: the rig YAML.
        json_path: write the segments here as JSON (``None``: nowhere).

    Returns:
        The segments.

    Raises:
        BrakeHilError: a bad rig file or recording, or no steady pulsing.
    """
    check_outputs(json_path)
    opened = open_recording(recording_path, rig_path)
    recording, rig = opened.recording, opened.rig
    with naming(recording_path):
        segments = tuple(characterize(recording, rig))
    document: dict[str, object] = {
        "recording": str(recording_path),
        "segments": [s.as_dict() for s in segments],
    }
    write_json(json_path, document)
    return CharacterizeResult(recording_path, rig_path, rig, segments, document, json_path)
