"""``brake-hil characterize``: the paper's Table 3 per steady segment, and per band of a sweep."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from brake_hil.analysis.characterization import SegmentCharacterization
from brake_hil.analysis.segmentation import Segment
from brake_hil.analysis.sweep_characterization import (
    SweepCharacterization,
    characterize_recording,
)
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
    sweeps: tuple[SweepCharacterization, ...] = ()  # Table 3 against frequency, per sweep
    found: tuple[Segment, ...] = ()  # every segment of the recording, of any kind


def run_characterize(
    recording_path: Path,
    rig_path: Path | None = None,
    json_path: Path | None = None,
) -> CharacterizeResult:
    """Characterise every steady segment (the paper's Table 3) and every sweep, per band.

    Args:
        recording_path: a recording with ``p_i`` and the three measured outputs.
        rig_path: the rig YAML (default: ``RECORDING.rig.yaml`` beside the recording).
        json_path: write the segments here as JSON (``None``: nowhere).

    The inputs are opened and checked before any output folder is made; a refusal after
    that removes the folders it made.

    Returns:
        The segments.

    Raises:
        BrakeHilError: no such recording, a bad rig file or recording, or neither steady
            pulsing nor a sweep.
    """
    opened = open_recording(recording_path, rig_path)  # the inputs first: a refusal writes nothing
    recording, rig, rig_path = opened.recording, opened.rig, opened.rig_path
    with removed_if_refused(None if json_path is None else json_path.parent):
        check_outputs(json_path)
        with naming(recording_path):
            found = characterize_recording(recording, rig)
        document: dict[str, object] = {
            "recording": str(recording_path),
            "segments": [s.as_dict() for s in found.steady],
            "sweeps": [s.as_dict() for s in found.sweeps],
            "segments_found": [s.as_dict() for s in found.segments],
        }
        write_json(json_path, document)
    return CharacterizeResult(
        recording_path,
        rig_path,
        rig,
        tuple(found.steady),
        document,
        json_path,
        tuple(found.sweeps),
        tuple(found.segments),
    )
