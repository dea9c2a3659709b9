"""Which recordings a command means: a recording, a folder of them, or a glob; their rig files.

A *recording* is a rosbag2 folder (``metadata.yaml`` or ``.mcap``/``.db3`` files in it) or a
bare ``.mcap``/``.db3`` file. A folder that is not a recording is searched for recordings
below it (links to folders are not followed, so a search never leaves the tree it was given
or loops). A pattern with ``*``, ``?`` or ``[`` that names no existing path is a glob
(``**`` reaches into subfolders).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
import glob
import os
from pathlib import Path

from brake_hil.errors import BrakeHilError
from brake_hil.io.recording_paths import RECORDING_SUFFIXES, recording_name, rig_beside

__all__ = [
    "RECORDING_SUFFIXES",
    "find_recordings",
    "is_recording",
    "mirrored_folder",
    "names_many",
    "recording_name",
    "rig_beside",
]

_GLOB_CHARACTERS = frozenset("*?[")


def is_recording(path: Path) -> bool:
    """True for a bare ``.mcap``/``.db3`` file or a folder holding a rosbag2 recording."""
    if path.is_file():
        return path.suffix in RECORDING_SUFFIXES
    if not path.is_dir():
        return False
    if (path / "metadata.yaml").is_file():
        return True
    return any(child.suffix in RECORDING_SUFFIXES and child.is_file() for child in path.iterdir())


def _below(folder: Path) -> list[Path]:
    """Every recording under ``folder`` (not ``folder`` itself), sorted; links not followed."""
    found = []
    for root, folders, files in os.walk(folder):
        here = Path(root)
        kept = []
        for name in sorted(folders):
            child = here / name
            if child.is_symlink():
                continue
            if is_recording(child):
                found.append(child)
            else:
                kept.append(name)
        folders[:] = kept
        found.extend(
            here / name
            for name in sorted(files)
            if Path(name).suffix in RECORDING_SUFFIXES and not (here / name).is_symlink()
        )
    return sorted(found)


def _unique_targets(paths: Iterable[Path]) -> list[Path]:
    """``paths`` sorted, one per real target (``**`` follows links: the shortest path kept)."""
    shortest: dict[str, Path] = {}
    for path in sorted(paths, key=lambda p: (len(p.parts), p)):
        shortest.setdefault(os.path.realpath(path), path)
    return sorted(shortest.values())


def find_recordings(patterns: Sequence[Path | str]) -> list[Path]:
    """The recordings ``patterns`` name, each once, in the order given (a folder's sorted).

    Raises:
        BrakeHilError: a pattern that names nothing, or a folder with no recording in it.
    """
    found: list[Path] = []
    for pattern in patterns:
        path = Path(pattern)
        if not path.exists() and _GLOB_CHARACTERS & set(str(pattern)):
            recordings = _unique_targets(
                m for m in map(Path, glob.glob(str(pattern), recursive=True)) if is_recording(m)
            )
            if not recordings:
                raise BrakeHilError(f"{pattern}: no recording matches this pattern")
        elif not path.exists():
            raise BrakeHilError(f"{pattern}: no such file or folder")
        elif is_recording(path):
            recordings = [path]
        elif path.is_dir():
            recordings = _below(path)
            if not recordings:
                raise BrakeHilError(f"{pattern}: no recording in this folder")
        else:
            raise BrakeHilError(f"{pattern}: not a recording (a rosbag2 folder, .mcap or .db3)")
        found.extend(recordings)
    return list(dict.fromkeys(found))


def names_many(patterns: Sequence[Path | str]) -> bool:
    """True when ``patterns`` mean many recordings: several, a glob, or a folder of them.

    One path that is a recording, or that is none of these (a missing file, an empty
    folder), is one recording: its command refuses it as such.
    """
    if len(patterns) != 1:
        return True
    path = Path(patterns[0])
    if not path.exists():
        return bool(_GLOB_CHARACTERS & set(str(patterns[0])))
    return path.is_dir() and not is_recording(path) and bool(_below(path))


def mirrored_folder(recording: Path, recordings: Sequence[Path], out: Path) -> Path:
    """``recording``'s own output folder under ``out``, mirroring where it sits among the others.

    ``fleet/rig-1/run-01`` among ``fleet/rig-*/run-*`` gets ``out/rig-1/run-01``; a bare
    ``x/run.mcap`` gets ``out/run``. Distinct recordings get distinct folders.
    """
    resolved = [Path(os.path.abspath(r)) for r in recordings]
    root = Path(os.path.commonpath([r.parent for r in resolved]))
    own = Path(os.path.abspath(recording))
    relative = own.parent.relative_to(root) / recording_name(own)
    if own.suffix in RECORDING_SUFFIXES and any(
        r != own and r.parent == own.parent and recording_name(r) == recording_name(own)
        for r in resolved
    ):
        relative = relative.with_name(own.name.replace(".", "_"))
    return out / relative
