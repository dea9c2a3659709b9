"""One recording opened for a command: read, checked, and its rig file found and loaded.

:func:`open_recording` is how the commands that work on a recording and its rig file
(``compare``, ``characterize``, ``diagnose``, ``benchmark``'s cases) get both: the rig file
(``--rig``, or ``RECORDING.rig.yaml`` beside the recording, :func:`rig_beside`) is loaded
first, then the recording is read and checked once
(:func:`~brake_hil.io.recording_reader.read_recording`: the path refused at the door, an
unfinished MCAP read from its whole chunks, every channel checked and aligned to ``p_i``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Final

from brake_hil.analysis.recording import Recording
from brake_hil.io.recording_paths import existing_recording, rig_beside
from brake_hil.io.recording_reader import read_recording
from brake_hil.physics.rig import Rig, load_rig
from brake_hil.topics import MASTER_CYLINDER_PRESSURE, MEASURED_OUTPUTS, TopicSpec

__all__ = ["MODEL_TOPICS", "OpenedRecording", "open_recording"]

MODEL_TOPICS: Final = (MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS)
"""What a recording must hold to be compared with the model: ``p_i`` and the three outputs."""


@dataclass(frozen=True)
class OpenedRecording:
    """A checked recording and the rig file it is read against."""

    recording: Recording
    rig_path: Path
    rig: Rig


def open_recording(
    path: Path | str, rig_path: Path | None = None, required: Sequence[TopicSpec] = MODEL_TOPICS
) -> OpenedRecording:
    """The rig file loaded, then the recording read and checked.

    Args:
        path: a rosbag2 directory, a ``.mcap`` or a ``.db3`` file.
        rig_path: the rig YAML (default: ``RECORDING.rig.yaml`` beside the recording).
        required: topics the recording must hold (default :data:`MODEL_TOPICS`).

    Returns:
        The recording and its rig.

    Raises:
        RecordingError: no such recording (nothing at ``path``).
        BrakeHilError: no rig file beside the recording (when ``rig_path`` is ``None``).
        RigError: a bad rig file (the message names it).
        RecordingError: a bad recording (the message names it; see
            :func:`~brake_hil.io.recording_reader.read_recording`).
    """
    path = existing_recording(Path(path))
    rig_path = rig_path if rig_path is not None else rig_beside(path)
    rig = load_rig(rig_path)
    return OpenedRecording(read_recording(path, required=required), rig_path, rig)
