"""What a result is about: a recording by its content, and the rig file it was judged against.

A recording is known by the SHA-256 of its storage files' bytes (``.mcap`` or ``.db3``, in
the files' recording order, each preceded by its length), not by its path or its
``metadata.yaml``: a bag moved, renamed or re-indexed is the same recording, and a re-recorded
one is new. The rig file is known by the SHA-256 of its content (the parsed YAML as canonical
JSON: comments, spacing and key order do not count), so a rig file whose values were edited
starts a new series of multipliers (they are relative to its values), while the same rig file
copied beside every recording with its own comment stays one.

The recording's span is its first and last log time, from the MCAP summary statistics when
every file has them (no message is read); else (an sqlite3 bag, an unfinished MCAP) the first
and last ``p_i`` stamp the recording reader finds
(:func:`~brake_hil.io.recording_reader.read_recording`). Either orders runs in time.
"""

from __future__ import annotations

from dataclasses import dataclass
import hashlib
import json
from pathlib import Path
import re
from typing import Final

from mcap.reader import make_reader

from brake_hil.errors import BrakeHilError, RecordingError, RigError
from brake_hil.files import load_yaml, read_text
from brake_hil.io.mcap_salvage import is_finished
from brake_hil.io.recording_checks import check_recording_path
from brake_hil.io.recording_reader import read_recording
from brake_hil.physics.rig import load_rig

__all__ = [
    "NO_RIG",
    "RecordingIdentity",
    "file_hash",
    "identify",
    "identify_loosely",
    "identify_with_model",
    "recording_hash",
    "recording_span",
    "rig_hash",
]

STORAGE_SUFFIXES: Final = (".mcap", ".db3")
"""Files of a recording whose bytes make its content hash."""
NO_RIG: Final = "no rig file"
"""Rig name and hash of a failure for which no rig file was found."""
_CHUNK_BYTES: Final = 1 << 20
_FILE_INDEX: Final = re.compile(r"_(\d+)\.(?:mcap|db3)$")


@dataclass(frozen=True)
class RecordingIdentity:
    """A recording and the rig file it was judged against, as the results store keys them."""

    path: str  # the recording as given (a bag folder, a .mcap or .db3 file)
    content_hash: str  # SHA-256 (hex) of the storage files' bytes
    start_ns: int | None  # first log time (ns since the epoch); None: the recording is unread
    end_ns: int | None  # last log time (ns since the epoch)
    rig_name: str  # the rig file's ``name``
    rig_hash: str  # SHA-256 (hex) of the rig file's content (rig_hash)
    rig_path: str  # the rig file as given

    @property
    def duration_s(self) -> float | None:
        """The span from first to last log time (s); None when the recording is unread."""
        if self.start_ns is None or self.end_ns is None:
            return None
        return (self.end_ns - self.start_ns) / 1e9


def _file_order(path: Path) -> tuple[int, str]:
    match = _FILE_INDEX.search(path.name)
    return (int(match.group(1)) if match else -1, path.name)


def _storage_files(recording: Path) -> list[Path]:
    """A recording's storage files in recording order (``_<index>`` suffix, then name)."""
    if not recording.is_dir():
        return [recording]
    found = [p for p in recording.iterdir() if p.suffix in STORAGE_SUFFIXES and p.is_file()]
    return sorted(found, key=_file_order)


def file_hash(path: Path) -> str:
    """SHA-256 (hex) of one file's bytes.

    Raises:
        OSError: the file cannot be read.
    """
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        while chunk := stream.read(_CHUNK_BYTES):
            digest.update(chunk)
    return digest.hexdigest()


def rig_hash(path: Path) -> str:
    """SHA-256 (hex) of a rig file's content: its YAML parsed, as canonical JSON.

    Raises:
        RigError: the file is missing or not strict YAML.
    """
    document = load_yaml(read_text(path, "rig file", RigError), path, RigError)
    canonical = json.dumps(document, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(canonical.encode()).hexdigest()


def recording_hash(recording: Path) -> str:
    """SHA-256 (hex) of a recording's storage files: each one's length (8 bytes), then bytes.

    Raises:
        RecordingError: the recording holds no storage file, or one cannot be read.
    """
    files = _storage_files(recording)
    if not files:
        raise RecordingError(f"{recording}: no .mcap or .db3 file to identify the recording by")
    digest = hashlib.sha256()
    for file in files:
        try:
            with file.open("rb") as stream:
                digest.update(file.stat().st_size.to_bytes(8, "little"))
                while chunk := stream.read(_CHUNK_BYTES):
                    digest.update(chunk)
        except OSError as err:
            problem = err.strerror or str(err)
            raise RecordingError(f"{recording}: cannot read {file.name}: {problem}") from err
    return digest.hexdigest()


def _summary_span(files: list[Path]) -> tuple[int, int] | None:
    """First and last log time (ns) from the MCAP summary statistics; None if one lacks them."""
    starts: list[int] = []
    ends: list[int] = []
    for file in files:
        if file.suffix != ".mcap" or not is_finished(file):
            return None
        try:
            with file.open("rb") as stream:
                summary = make_reader(stream).get_summary()
        except Exception:  # noqa: BLE001 - any failure: the recording reader decides
            return None
        statistics = summary.statistics if summary is not None else None
        if statistics is None or statistics.message_count == 0:
            return None
        starts.append(int(statistics.message_start_time))
        ends.append(int(statistics.message_end_time))
    return (min(starts), max(ends)) if starts else None


def recording_span(recording: Path) -> tuple[int, int]:
    """A recording's first and last log time (ns since the epoch; module docstring).

    Raises:
        RecordingError: the recording is missing, not a recording, or unreadable.
    """
    if (span := _summary_span(_storage_files(recording))) is not None:
        return span
    read = read_recording(recording)
    return read.start_stamp_ns, read.start_stamp_ns + round(float(read.time[-1]) * 1e9)


def identify(recording: Path, rig: Path) -> RecordingIdentity:
    """The identity of ``recording`` judged against the rig file ``rig``.

    Raises:
        RecordingError: the recording is missing, not a recording, or unreadable.
        RigError: the rig file is missing or invalid.
    """
    check_recording_path(recording)
    if not recording.exists():
        raise RecordingError(f"{recording}: no such file or directory")
    rig_name = load_rig(rig).name
    start_ns, end_ns = recording_span(recording)
    return RecordingIdentity(
        path=str(recording),
        content_hash=recording_hash(recording),
        start_ns=start_ns,
        end_ns=end_ns,
        rig_name=rig_name,
        rig_hash=rig_hash(rig),
        rig_path=str(rig),
    )


def identify_with_model(recording: Path, model_file: Path) -> RecordingIdentity:
    """The identity of ``recording`` replayed through a model file (``regress``).

    The model file stands where a rig file would: its file name for the rig's name, the
    SHA-256 of its bytes for the rig's hash.

    Raises:
        RecordingError: the recording is missing, not a recording, or unreadable.
        OSError: the model file cannot be read.
    """
    check_recording_path(recording)
    start_ns, end_ns = recording_span(recording)
    return RecordingIdentity(
        path=str(recording),
        content_hash=recording_hash(recording),
        start_ns=start_ns,
        end_ns=end_ns,
        rig_name=f"model {model_file.name}",
        rig_hash=file_hash(model_file),
        rig_path=str(model_file),
    )


def _path_hash(path: Path) -> str:
    return "path:" + hashlib.sha256(str(path).encode()).hexdigest()


def identify_loosely(recording: Path, rig: Path | None) -> RecordingIdentity:
    """The identity of a recording whose command failed: what can be known, never raising.

    Its span is unknown (None). A recording or rig file that cannot be read is known by the
    SHA-256 of its path instead (``path:`` before the hex), a rig without a valid ``name`` by
    its file name; no rig file (``None``: none was found) by :data:`NO_RIG`.
    """
    try:
        content = recording_hash(recording)
    except (BrakeHilError, OSError):
        content = _path_hash(recording)
    if rig is None:
        rig_content, rig_name = NO_RIG, NO_RIG
    else:
        try:
            rig_content = rig_hash(rig)
        except BrakeHilError:
            rig_content = _path_hash(rig)
        try:
            rig_name = load_rig(rig).name
        except BrakeHilError:
            rig_name = rig.name.removesuffix(".yaml").removesuffix(".rig")
    return RecordingIdentity(
        path=str(recording),
        content_hash=content,
        start_ns=None,
        end_ns=None,
        rig_name=rig_name,
        rig_hash=rig_content,
        rig_path="" if rig is None else str(rig),
    )
