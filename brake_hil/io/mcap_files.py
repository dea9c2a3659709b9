"""One ``.mcap`` file of a recording, written so that it survives ``kill -9`` (ROS-free).

The ``mcap`` writer writes into a memory buffer (:class:`CommitStream`); a finished chunk is
committed to the file together with a temporary MCAP footer (no summary) by one ``pwrite``,
at the place of the previous temporary footer, so the file on disk always ends after a whole
chunk with a valid footer. A failed write cuts the file back to its last whole chunk.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import os
from pathlib import Path
import struct
from typing import Final, NamedTuple

from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter
from rosbags.interfaces import Qos

from brake_hil import __version__

__all__ = ["MCAP_MAGIC", "CommitStream", "Counts", "FileInfo", "OpenFile", "TopicInfo"]

MCAP_MAGIC: Final = b"\x89MCAP0\r\n"
_FOOTER: Final = b"\x02" + struct.pack("<QQQI", 20, 0, 0, 0) + MCAP_MAGIC
"""An MCAP footer without summary (summary_start 0, summary_offset_start 0, crc 0) + magic."""


class TopicInfo(NamedTuple):
    """One recorded topic, as ``metadata.yaml`` and the MCAP channel describe it."""

    name: str
    msgtype: str  # e.g. "sensor_msgs/msg/FluidPressure"
    msgdef: str  # ros2msg text (rosbags' generate_msgdef format)
    type_hash: str  # RIHS01 type description hash
    offered_qos_profiles: tuple[Qos, ...]
    serialization_format: str = "cdr"


class FileInfo(NamedTuple):
    """One storage file's share of the recording (committed messages only)."""

    path: Path
    message_count: int
    start_ns: int  # first log time (ns); 0 when empty
    end_ns: int  # last log time (ns); 0 when empty
    size_bytes: int


@dataclass
class Counts:
    """Message counts and log-time span of a set of messages."""

    per_topic: dict[int, int] = field(default_factory=dict)
    start_ns: int | None = None
    end_ns: int | None = None

    @property
    def total(self) -> int:
        """Messages of every topic."""
        return sum(self.per_topic.values())

    def add(self, topic: int, log_time_ns: int, count: int = 1) -> None:
        """Count ``count`` messages of ``topic`` logged at ``log_time_ns``."""
        self.per_topic[topic] = self.per_topic.get(topic, 0) + count
        self.start_ns = log_time_ns if self.start_ns is None else min(self.start_ns, log_time_ns)
        self.end_ns = log_time_ns if self.end_ns is None else max(self.end_ns, log_time_ns)

    def merge(self, other: Counts) -> None:
        """Add ``other``'s counts and span to these."""
        for topic, count in other.per_topic.items():
            self.per_topic[topic] = self.per_topic.get(topic, 0) + count
        if other.start_ns is not None and other.end_ns is not None:
            self.start_ns = min(other.start_ns, self.start_ns or other.start_ns)
            self.end_ns = max(other.end_ns, self.end_ns or other.end_ns)


class CommitStream:
    """The byte stream the ``mcap`` writer writes to: buffered until :meth:`commit`."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        self._committed = 0  # bytes of real content on disk (the temporary footer follows)
        self._pending = bytearray()

    @property
    def pending(self) -> int:
        """Bytes written but not committed yet."""
        return len(self._pending)

    @property
    def size(self) -> int:
        """Committed bytes (the temporary footer not counted)."""
        return self._committed

    def write(self, data: bytes | bytearray | memoryview) -> int:
        """Buffer ``data`` until the next commit; its length."""
        self._pending += data
        return len(data)

    def tell(self) -> int:
        """The stream position: committed plus pending bytes."""
        return self._committed + len(self._pending)

    def flush(self) -> None:
        """No-op: content reaches the file only through :meth:`commit`."""

    def commit(self, final: bool = False) -> None:
        """Write the pending bytes (plus a temporary footer unless ``final``) in one pwrite.

        Raises:
            OSError: the write failed (disk full, file size limit, I/O error); the file is
                put back as it was after the last commit (see :meth:`roll_back`) and the
                pending bytes are dropped.
        """
        data = bytes(self._pending) if final else bytes(self._pending) + _FOOTER
        view, offset = memoryview(data), self._committed
        try:
            while view:
                written = os.pwrite(self._fd, view, offset)
                view, offset = view[written:], offset + written
            if final:
                os.ftruncate(self._fd, self._committed + len(self._pending))
        except OSError:
            self._pending.clear()
            self.roll_back()
            raise
        self._committed += len(self._pending)
        self._pending.clear()

    def discard(self) -> None:
        """Drop the pending bytes."""
        self._pending.clear()

    def roll_back(self) -> bool:
        """Cut the file back to its last commit and its temporary footer; True when it worked.

        The blocks up to the old footer's end were allocated before, so this needs no new
        space: after a failed write on a full disk the file is again a valid MCAP (no
        summary) holding every committed chunk.
        """
        try:
            os.ftruncate(self._fd, self._committed + len(_FOOTER))
            os.pwrite(self._fd, _FOOTER, self._committed)
        except OSError:
            return False
        return True

    def close(self) -> None:
        """Close the file as it is on disk."""
        os.close(self._fd)


class OpenFile:
    """One ``.mcap`` being written."""

    def __init__(self, path: Path, chunk_bytes: int, compression: CompressionType) -> None:
        self.path = path
        self.stream = CommitStream(path)
        self.writer = McapWriter(
            self.stream,  # type: ignore[arg-type]
            chunk_size=chunk_bytes,
            compression=compression,
            enable_crcs=True,
        )
        try:
            self.writer.start(profile="ros2", library=f"brake_hil {__version__}")
            self.stream.commit()  # header + temporary footer: a valid empty MCAP from the start
        except OSError:
            self.stream.close()
            raise
        self.schema_ids: dict[str, int] = {}
        self.channel_ids: dict[int, int] = {}  # topic handle -> MCAP channel id
        self.committed = Counts()
        self.pending = Counts()
        self.first_log_ns: int | None = None
        self.pending_since_ns = 0  # monotonic time of the pending chunk's first message

    def add_topic(self, handle: int, topic: TopicInfo, qos_text: str) -> None:
        """Register ``topic`` (its schema once per type) as the channel of ``handle``."""
        if (schema := self.schema_ids.get(topic.msgtype)) is None:
            schema = self.writer.register_schema(topic.msgtype, "ros2msg", topic.msgdef.encode())
            self.schema_ids[topic.msgtype] = schema
        metadata = {"offered_qos_profiles": qos_text, "topic_type_hash": topic.type_hash}
        self.channel_ids[handle] = self.writer.register_channel(
            topic.name, topic.serialization_format, schema, metadata
        )

    def info(self) -> FileInfo:
        """What this file holds on disk so far."""
        counts = self.committed
        return FileInfo(
            self.path, counts.total, counts.start_ns or 0, counts.end_ns or 0, self.stream.size
        )
