"""A recording's name and the rig file beside it, from its path alone (nothing is read).

Light on purpose (no numpy, no rosbags): ``brake-hil --help`` imports it.
"""

from __future__ import annotations

import difflib
import os
from pathlib import Path
from typing import Final

from brake_hil.errors import BrakeHilError, RecordingError

__all__ = ["RECORDING_SUFFIXES", "existing_recording", "recording_name", "rig_beside"]

RECORDING_SUFFIXES: Final = (".mcap", ".db3")
"""Suffixes of the files a rosbag2 recording is stored in."""


def existing_recording(recording: Path) -> Path:
    """``recording``, refused when nothing is there.

    A typo is named as such, before the rig file beside it is looked for and before any
    output is made.

    Raises:
        RecordingError: "no such recording", naming the path, and the closest name beside it
            when one is close (``difflib``): ``did you mean bags/effect_hose_compliance?``.
    """
    if not os.path.lexists(recording):
        base = Path(str(recording).rstrip("/"))
        try:
            names = [p.name for p in base.parent.iterdir() if not p.name.endswith(".yaml")]
        except OSError:
            names = []
        close = difflib.get_close_matches(base.name, names, n=1, cutoff=0.6)
        hint = f"; did you mean {base.parent / close[0]}?" if close else ""
        raise RecordingError(f"{recording}: no such recording{hint}")
    return recording


def rig_beside(recording: Path, option: str = "--rig") -> Path:
    """``RECORDING.rig.yaml`` beside a recording (a bag folder or a bare ``.mcap``/``.db3``).

    Args:
        recording: the recording's path.
        option: the option the message tells the user to pass instead.

    Raises:
        BrakeHilError: no rig file beside it (the message says to pass ``option``).
    """
    base = Path(str(recording).rstrip("/"))
    candidates = [base.parent / f"{base.name}.rig.yaml"]
    if base.suffix in RECORDING_SUFFIXES:
        candidates.append(base.with_suffix(".rig.yaml"))
    for path in candidates:
        if path.is_file():
            return path
    raise BrakeHilError(f"{recording}: no rig file beside it ({candidates[0]}); pass {option}")


def recording_name(recording: Path) -> str:
    """A recording's name: its folder's, or its file's without the suffix."""
    base = Path(str(recording).rstrip("/"))
    return base.stem if base.suffix in RECORDING_SUFFIXES else base.name
