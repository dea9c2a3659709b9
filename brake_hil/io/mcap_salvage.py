"""What an unfinished MCAP file holds: its whole records, read in order without seeking.

A file is *finished* when it ends with a footer that points at a summary section (what a
writer leaves when it is closed). A writer killed (``kill -9``, power loss) or stopped by a
full disk leaves no summary, or a cut record at the end. :func:`salvage_file` then streams the
file with python ``mcap``'s :class:`~mcap.stream_reader.StreamReader` (no seeking, no summary
needed) and keeps every record up to the first one that is cut off or corrupt: each chunk is
kept only when it decompresses and its CRC matches, so no partial chunk is ever read as data.

ROS-free; the rosbag2 side (directories, ``metadata.yaml``) is
:mod:`brake_hil.io.unfinished`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
import struct
from typing import Final, NamedTuple

from mcap.exceptions import EndOfFile, McapError
from mcap.records import (
    Channel,
    Chunk,
    DataEnd,
    Footer,
    Header,
    McapRecord,
    Message,
    Metadata,
    Schema,
)
from mcap.stream_reader import StreamReader, breakup_chunk
from zstandard import ZstdError

MAGIC: Final = b"\x89MCAP0\r\n"
_FOOTER_OPCODE: Final = 0x02
_FOOTER_TAIL: Final = 1 + 8 + 20 + len(MAGIC)
"""Bytes of a footer record (opcode, length, 20-byte body) and the closing magic."""


class SalvagedMessage(NamedTuple):
    """One message read from a whole chunk (or written outside chunks)."""

    channel_id: int
    log_time_ns: int
    publish_time_ns: int
    sequence: int
    data: bytes


@dataclass
class SalvagedFile:
    """What :func:`salvage_file` read from one MCAP file.

    Attributes:
        path: the file.
        finished: it ends with a footer pointing at a summary (nothing to recover).
        profile: the header's profile (``"ros2"`` for rosbag2).
        schemas: schema records by id.
        channels: channel records by id.
        messages: every message of the whole chunks, in file order.
        metadata: metadata records by name (``"rosbag2"`` when the writer was rosbag2's).
        read_bytes: bytes from the file's start to the end of the last whole record kept.
        size_bytes: the file's size.
        stop: why reading stopped before a footer with summary ("" when finished).
    """

    path: Path
    finished: bool = False
    profile: str = ""
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    messages: list[SalvagedMessage] = field(default_factory=list)
    metadata: dict[str, Mapping[str, str]] = field(default_factory=dict)
    read_bytes: int = 0
    size_bytes: int = 0
    stop: str = ""

    @property
    def lost_bytes(self) -> int:
        """Bytes after the last whole record kept (cut off or unreadable)."""
        return self.size_bytes - self.read_bytes


def is_finished(path: Path | str) -> bool:
    """True when ``path`` starts with the MCAP magic and ends with a footer and a summary.

    Reads 8 bytes at each end; says nothing about the records between.
    """
    with Path(path).open("rb") as stream:
        head = stream.read(len(MAGIC))
        size = stream.seek(0, 2)
        if head != MAGIC or size < len(MAGIC) + _FOOTER_TAIL:
            return False
        stream.seek(size - _FOOTER_TAIL)
        tail = stream.read(_FOOTER_TAIL)
    opcode, length, summary_start = struct.unpack_from("<BQQ", tail)
    return tail.endswith(MAGIC) and opcode == _FOOTER_OPCODE and length == 20 and summary_start > 0


def _reason(err: BaseException, offset: int) -> str:
    if isinstance(err, (EndOfFile, struct.error, EOFError)):
        return f"the file ends inside a record at byte {offset}"
    text = " ".join(str(err).split()) or type(err).__name__
    return f"a corrupt record at byte {offset} ({text})"


def salvage_file(path: Path | str) -> SalvagedFile:
    """Read every whole record of an MCAP file in order, up to the first cut or corrupt one.

    Chunks are checked (decompression, CRC of their content) before any of their messages is
    kept. Records of a summary section are not needed and are skipped.

    Args:
        path: an MCAP file, finished or not.

    Returns:
        What was read; ``stop`` says why reading ended when no footer with summary was met.

    Raises:
        OSError: the file cannot be opened or read.
    """
    path = Path(path)
    found = SalvagedFile(path, size_bytes=path.stat().st_size)
    in_summary = False
    with path.open("rb") as stream:
        records = StreamReader(stream, emit_chunks=True, validate_crcs=True).records
        while True:
            start = stream.tell()
            try:
                record = next(records)
                inner = (
                    breakup_chunk(record, validate_crc=True) if isinstance(record, Chunk) else []
                )
            except StopIteration:  # the footer and the closing magic were read
                found.read_bytes = stream.tell()
                found.stop = "" if found.finished else "a footer without summary"
                return found
            except (McapError, ZstdError, ValueError, RuntimeError, struct.error, EOFError) as err:
                # zstd raises ZstdError (an Exception, not a ValueError) on corrupt data,
                # lz4.frame RuntimeError
                found.finished = False
                found.stop = _reason(err, start) if start else "no MCAP header (bad magic)"
                return found
            end = stream.tell()
            if isinstance(record, Footer):
                found.finished = record.summary_start > 0
                found.read_bytes = end
                continue
            if isinstance(record, DataEnd):
                in_summary = True
            elif not in_summary:
                _keep(found, record, inner)
            found.read_bytes = end


def _keep(found: SalvagedFile, record: McapRecord, inner: Sequence[McapRecord]) -> None:
    """Add a data-section record (a chunk's content when it is a chunk) to ``found``."""
    for item in inner or [record]:
        if isinstance(item, Message):
            found.messages.append(
                SalvagedMessage(
                    item.channel_id, item.log_time, item.publish_time, item.sequence, item.data
                )
            )
        elif isinstance(item, Schema):
            found.schemas.setdefault(item.id, item)
        elif isinstance(item, Channel):
            found.channels.setdefault(item.id, item)
        elif isinstance(item, Metadata):
            found.metadata[item.name] = dict(item.metadata)
        elif isinstance(item, Header):
            found.profile = item.profile
