"""A recording's name and the rig file beside it, from its path alone (nothing is read).

Light on purpose (no numpy, no rosbags): ``brake-hil --help`` imports it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Final

from brake_hil.errors import BrakeHilError

__all__ = ["RECORDING_SUFFIXES", "recording_name", "rig_beside"]

RECORDING_SUFFIXES: Final = (".mcap", ".db3")
"""Suffixes of the files a rosbag2 recording is stored in."""


def rig_beside(recording: Path) -> Path:
    """``RECORDING.rig.yaml`` beside a recording (a bag folder or a bare ``.mcap``/``.db3``).

    Raises:
        BrakeHilError: no such file (the message says to pass ``--rig``).
    """
    base = Path(str(recording).rstrip("/"))
    candidates = [base.parent / f"{base.name}.rig.yaml"]
    if base.suffix in RECORDING_SUFFIXES:
        candidates.append(base.with_suffix(".rig.yaml"))
    for path in candidates:
        if path.is_file():
            return path
    raise BrakeHilError(f"{recording}: no rig file beside it ({candidates[0]}); pass --rig")


def recording_name(recording: Path) -> str:
    """A recording's name: its folder's, or its file's without the suffix."""
    base = Path(str(recording).rstrip("/"))
    return base.stem if base.suffix in RECORDING_SUFFIXES else base.name
