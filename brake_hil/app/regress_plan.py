"""Which recordings ``brake-hil regress`` replays, each through which model file.

:func:`plan_replays`: ``--model`` for all, else the baseline's model file when it names
one, else each recording's own rig file (``RECORDING.rig.yaml`` beside it);
:func:`rig_spread`: how far from 100 % the recording's rig lets a ptp ratio sit.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

from brake_hil.analysis.recording import Recording
from brake_hil.app.recordings import find_recordings, rig_beside
from brake_hil.diagnosis.ptp_spread import ptp_spread
from brake_hil.errors import BrakeHilError, RecordingError
from brake_hil.physics.rig import load_rig

__all__ = ["Plan", "plan_replays", "rig_spread"]


class Plan(NamedTuple):
    """Which recordings are replayed through which model file, and what was skipped."""

    jobs: list[tuple[Path, Path]]  # (recording, model file)
    sources: dict[Path, str]  # recording -> where its model file came from
    refused: dict[str, str]  # path -> why it is not replayed (one line naming it)


def _model_for(recording: Path, model_file: Path | None, stored: Path | None) -> tuple[Path, str]:
    """The model file a recording is replayed through, and where it came from."""
    if model_file is not None:
        return model_file, "--model"
    if stored is not None:
        return stored, "the baseline's model file"
    return rig_beside(recording, "--model"), "beside the recording"


def plan_replays(
    paths: Sequence[Path], model_file: Path | None = None, stored: Path | None = None
) -> Plan:
    """The recordings ``paths`` name, each with its model file.

    A folder of recordings gives each recording in it. A path that holds no recording (a
    folder of rig files, a file that is no recording), or a recording without a rig file
    beside it when neither ``model_file`` nor ``stored`` is given, is refused with its reason.

    Raises:
        RecordingError: a path that does not exist ("no such recording").
    """
    jobs: list[tuple[Path, Path]] = []
    sources: dict[Path, str] = {}
    refused: dict[str, str] = {}
    for path in paths:
        if not Path(path).exists():
            raise RecordingError(f"{path}: no such recording")
        try:
            found = find_recordings([path])
        except BrakeHilError as err:
            refused[str(path)] = str(err)
            continue
        for recording in found:
            try:
                model, source = _model_for(recording, model_file, stored)
            except BrakeHilError as err:
                refused[str(recording)] = str(err)
                continue
            jobs.append((recording, model))
            sources[recording] = source
    return Plan(jobs, sources, refused)


def rig_spread(recording: Recording, path: Path, model_file: Path) -> dict[str, float]:
    """The ptp spread (:func:`.ptp_spread.ptp_spread`) of the rig the recording was made on.

    Its rig: the model file when it is a rig file, else the rig file beside the recording.
    Empty when neither, or without steady pulsing (``far_off`` then takes the comparator's
    level).
    """
    try:
        rig_path = Path(model_file)
        if rig_path.suffix not in (".yaml", ".yml"):
            rig_path = rig_beside(path)
        return ptp_spread(recording, load_rig(rig_path))
    except BrakeHilError:
        return {}
