"""``brake-hil characterize``: the paper's Table 3 (and Table 1) per steady segment."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from brake_hil.analysis.characterization import SegmentCharacterization, characterize
from brake_hil.app.naming import naming
from brake_hil.app.output import check_outputs, removed_if_refused, write_json
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
    recording_path: Path,
    rig_path: Path | None = None,
    json_path: Path | None = None,
) -> CharacterizeResult:
    """Characterise every steady segment of the recording (the paper's Table 3).

    Args:
        recording_path: a recording with ``p_i`` and the three measured outputs.
        rig_path: the rig YAML (default: ``RECORDING.rig.yaml`` beside the recording).
        json_path: write the segments here as JSON (``None``: nowhere).

    The inputs are opened and checked before any output folder is made; a refusal after
    that removes the folders it made.

    Returns:
        The segments.

    Raises:
        BrakeHilError: no such recording, a bad rig file or recording, or no steady pulsing.
    """
    opened = open_recording(recording_path, rig_path)  # the inputs first: a refusal writes nothing
    recording, rig, rig_path = opened.recording, opened.rig, opened.rig_path
    with removed_if_refused(None if json_path is None else json_path.parent):
        check_outputs(json_path)
        with naming(recording_path):
            segments = tuple(characterize(recording, rig))
        document: dict[str, object] = {
            "recording": str(recording_path),
            "segments": [s.as_dict() for s in segments],
        }
        write_json(json_path, document)
    return CharacterizeResult(recording_path, rig_path, rig, segments, document, json_path)
