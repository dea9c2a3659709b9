"""Stream serialised messages into a rosbag2 MCAP directory that survives ``kill -9`` (ROS-free).

The directory is what ``ros2 bag record -s mcap`` writes: ``metadata.yaml`` (rosbag2 version 9)
and ``<name>_0.mcap``, ``<name>_1.mcap``, ... (profile ``ros2``, one ``ros2msg`` schema per
type, channels with ``offered_qos_profiles`` and ``topic_type_hash``, CDR messages as given, in
zstd chunks with CRCs, then indexes, statistics and a ``rosbag2`` metadata record when a file
is closed). A new file starts when the current one reaches ``max_file_bytes`` (checked at each
chunk, so a file may exceed it by one chunk) or spans ``max_file_duration_s`` of log time.

Crash safety. The ``mcap`` writer writes into a memory buffer; a finished chunk is committed
to the file together with a temporary MCAP footer (no summary) by one ``pwrite``, at the place
of the previous temporary footer. The file on disk therefore always ends after a whole chunk
with a valid footer: after ``kill -9`` every file is a complete MCAP without summary, which
rosbags and ``mcap`` read by scanning. Only the chunk in memory is lost (at most
``chunk_bytes`` of messages, or ``max_chunk_age_s`` of them when the caller also calls
``flush()`` on a timer of that period).
``metadata.yaml`` is rewritten (write-then-rename) after every commit with the counts now on
disk and every file so far (with ``metadata_interval_s``, at most that often, and whenever
a file starts or closes), so a killed recording opens as it stands. A kill between the
chunk's ``pwrite`` and the rename (microseconds) leaves counts one chunk short;
:func:`recover_metadata` rewrites ``metadata.yaml`` from the files, as ``ros2 bag reindex``
does.

Write errors. When a write fails (disk full, a file size limit, an I/O error) the file is cut
back to its last whole chunk and temporary footer, and the recording stops with
:class:`~brake_hil.errors.RecordingWriteError`, which names the file, the system's reason
and how many messages are on disk: every one of them reads back.
:mod:`brake_hil.io.unfinished` reads such a recording, ``brake-hil recover`` writes a
finished copy of it.

Messages are written as given (no decoding); log time is whatever the caller passes (a
recorder passes the receive time; ``header.stamp`` stays inside the message).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from contextlib import suppress
import copy
import errno
from pathlib import Path
import time

from mcap.writer import CompressionType
from rosbags.interfaces import Qos
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from brake_hil.errors import RecordingWriteError
from brake_hil.io.bag_metadata import (
    METADATA_VERSION,
    bag_metadata,
    dump_metadata,
    qos_text,
    recover_metadata,
    replace_text,
)
from brake_hil.io.closing import Closing
from brake_hil.io.mcap_files import MCAP_MAGIC, Counts, FileInfo, OpenFile, TopicInfo

__all__ = [
    "MCAP_MAGIC",
    "METADATA_VERSION",
    "FileInfo",
    "McapRecorder",
    "TopicInfo",
    "recover_metadata",
]


class McapRecorder(Closing):
    """Write serialised messages into a new rosbag2 MCAP directory, as they arrive.

    Args:
        path: the directory to create; must not exist. Files are ``<dir name>_<i>.mcap``.
        max_file_bytes: start a new file once the current one holds this many bytes
            (checked per chunk); None: no size limit.
        max_file_duration_s: start a new file before a message whose log time is this many
            seconds after the file's first message; None: no duration limit.
        chunk_bytes: uncompressed size of an MCAP chunk (bytes); a chunk is the unit that
            reaches the disk, so at most this much is lost by ``kill -9``.
        max_chunk_age_s: commit the chunk in progress at the first message written this long
            (s, monotonic) after the chunk's first message; None: only full chunks and
            :meth:`flush` commit. With a timer calling :meth:`flush` at the same interval,
            ``kill -9`` loses at most this span of messages (plus what the caller had not
            yet passed to :meth:`write`).
        metadata_interval_s: rewrite ``metadata.yaml`` at a chunk commit only when the last
            rewrite is this long ago (s); None: at every commit. It is always rewritten when
            a file starts or closes, so it lists every file; between rewrites its counts lag
            (the project's reader and ``brake-hil recover`` count the files themselves).
        compression: ``"zstd"``, ``"lz4"`` or ``"none"`` (chunk compression).
        custom_data: ``custom_data`` of ``metadata.yaml`` (strings).
        typestore: where message definitions and hashes come from (default ROS 2 Kilted).

    A failed write (disk full, file size limit, I/O error) stops the recording: the file is
    cut back to its last whole chunk and temporary footer (a valid MCAP without summary, every
    committed message readable), the pending chunk is dropped, ``metadata.yaml`` keeps its
    last counts (rewritten with those on disk at :meth:`close` when the disk allows), and
    :meth:`write` and :meth:`flush` raise :class:`~brake_hil.errors.RecordingWriteError`
    (also kept in :attr:`failure`) from then on; :meth:`close` then closes the file without
    a summary (``brake-hil recover`` writes a finished copy).

    Raises:
        FileExistsError: ``path`` exists.
        ValueError: a limit that is not positive, an unknown compression.
    """

    def __init__(
        self,
        path: Path | str,
        *,
        max_file_bytes: int | None = None,
        max_file_duration_s: float | None = None,
        chunk_bytes: int = 1 << 20,
        max_chunk_age_s: float | None = None,
        metadata_interval_s: float | None = None,
        compression: str = "zstd",
        custom_data: Mapping[str, str] | None = None,
        typestore: Typestore | None = None,
    ) -> None:
        self.path = Path(path)
        for name, limit in (
            ("max_file_bytes", max_file_bytes),
            ("max_file_duration_s", max_file_duration_s),
            ("chunk_bytes", chunk_bytes),
            ("max_chunk_age_s", max_chunk_age_s),
        ):
            if limit is not None and not limit > 0:
                raise ValueError(f"{name} must be > 0, got {limit}")
        compressions = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4}
        compressions["none"] = CompressionType.NONE
        if compression not in compressions:
            raise ValueError(f"compression must be one of {sorted(compressions)}")
        self._compression = compressions[compression]
        self._max_bytes = max_file_bytes
        self._max_duration_ns = (
            None if max_file_duration_s is None else round(max_file_duration_s * 1e9)
        )
        self._chunk_bytes = chunk_bytes
        self._max_chunk_age_ns = None if max_chunk_age_s is None else round(max_chunk_age_s * 1e9)
        self._metadata_interval_s = metadata_interval_s
        self._metadata_written = -float("inf")  # monotonic time of the last rewrite (s)
        self.failure: RecordingWriteError | None = None
        """Why writing stopped; None while the recording is healthy."""
        self._custom_data = dict(custom_data or {})
        self._typestore = typestore
        if self.path.exists():
            raise FileExistsError(f"{self.path}: exists already, not overwriting a recording")
        self.path.mkdir(parents=True)
        self.topics: list[TopicInfo] = []
        """Registered topics; a topic's handle is its index."""
        self._qos_texts: list[str] = []
        self._closed_files: list[FileInfo] = []
        self._counts: dict[int, int] = {}  # committed messages per topic handle, all files
        self._file: OpenFile | None = None
        self._open_next_file()

    # -- set-up --------------------------------------------------------------------------

    def _typestore_or_default(self) -> Typestore:
        if self._typestore is None:
            self._typestore = get_typestore(Stores.ROS2_KILTED)
        return self._typestore

    def add_topic(
        self,
        name: str,
        msgtype: str,
        *,
        offered_qos_profiles: Sequence[Qos] = (),
        msgdef: str | None = None,
        type_hash: str | None = None,
        serialization_format: str = "cdr",
    ) -> int:
        """Register a topic; returns its handle for :meth:`write`.

        ``msgdef`` (ros2msg text) and ``type_hash`` (RIHS01) default to the typestore's.

        Raises:
            ValueError: the topic is registered already, or the typestore does not know
                ``msgtype`` and no ``msgdef``/``type_hash`` are given.
            RecordingWriteError: writing failed now or before (see the class doc).
        """
        if self.failure is not None:
            raise self.failure
        if any(t.name == name for t in self.topics):
            raise ValueError(f"{self.path}: topic {name} is registered already")
        if msgdef is None or type_hash is None:
            store = self._typestore_or_default()
            if msgtype not in store.fielddefs:
                msg = f"{self.path}: {name}: message type {msgtype} is not in the typestore"
                raise ValueError(msg)
            if msgdef is None:
                msgdef = store.generate_msgdef(msgtype, ros_version=2)[0]
            type_hash = type_hash if type_hash is not None else store.hash_rihs01(msgtype)
        topic = TopicInfo(
            name, msgtype, msgdef, type_hash, tuple(offered_qos_profiles), serialization_format
        )
        handle = len(self.topics)
        self.topics.append(topic)
        self._qos_texts.append(qos_text(topic.offered_qos_profiles))
        assert self._file is not None
        self._file.add_topic(handle, topic, self._qos_texts[handle])
        try:
            self._write_metadata()
        except OSError as err:
            raise self._fail(err) from err
        return handle

    # -- writing -------------------------------------------------------------------------

    def write(
        self, handle: int, log_time_ns: int, data: bytes, publish_time_ns: int | None = None
    ) -> None:
        """Append one serialised message of topic ``handle``.

        ``log_time_ns`` is its log time (ns since the epoch), also written as publish time
        unless ``publish_time_ns`` is given.

        Raises:
            RecordingWriteError: writing failed now or before (see the class doc).
            ValueError: the recording is closed.
        """
        if self.failure is not None:
            raise self.failure
        current = self._file
        if current is None:
            raise ValueError(f"{self.path}: the recording is closed")
        try:
            self._write(current, handle, log_time_ns, data, publish_time_ns)
        except OSError as err:
            raise self._fail(err) from err

    def _write(
        self,
        current: OpenFile,
        handle: int,
        log_time_ns: int,
        data: bytes,
        publish_time_ns: int | None,
    ) -> None:
        if current.first_log_ns is None:
            current.first_log_ns = log_time_ns
        elif (
            self._max_duration_ns is not None
            and log_time_ns - current.first_log_ns >= self._max_duration_ns
        ):
            self._split()
            assert self._file is not None
            current = self._file
            current.first_log_ns = log_time_ns
        publish = log_time_ns if publish_time_ns is None else publish_time_ns
        current.writer.add_message(current.channel_ids[handle], log_time_ns, data, publish)
        if not current.pending.per_topic:
            current.pending_since_ns = time.monotonic_ns()
        current.pending.add(handle, log_time_ns)
        if current.stream.pending:  # the writer finished a chunk
            self._commit()
        elif (
            self._max_chunk_age_ns is not None
            and time.monotonic_ns() - current.pending_since_ns >= self._max_chunk_age_ns
        ):
            current.writer.flush()  # type: ignore[no-untyped-call]
            self._commit()

    def flush(self) -> None:
        """Commit the chunk in progress now (call on a timer to bound what ``kill -9`` loses).

        Raises:
            RecordingWriteError: writing failed now or before (see the class doc).
        """
        if self.failure is not None:
            raise self.failure
        if self._file is not None and self._file.pending.total:
            try:
                self._file.writer.flush()  # type: ignore[no-untyped-call]
                self._commit()
            except OSError as err:
                raise self._fail(err) from err

    def _fail(self, err: OSError) -> RecordingWriteError:
        """Stop the recording after a failed write: keep what is on disk, drop the rest."""
        current = self._file
        where = self.path
        if current is not None:
            where = current.stream.path
            current.stream.discard()
            current.stream.roll_back()
            current.pending = Counts()
        with suppress(OSError):
            (self.path / "metadata.yaml.tmp").unlink(missing_ok=True)
        code = errno.errorcode.get(err.errno or 0, "")
        reason = f"{err.strerror or err} ({code})" if code else str(err.strerror or err)
        on_disk = sum(self._counts.values())
        self.failure = RecordingWriteError(
            f"{where}: cannot write the recording: {reason}; recording stopped, the "
            f"{on_disk} messages committed before stay readable"
        )
        return self.failure

    def _commit(self, split: bool = True) -> None:
        """Put the finished chunk on disk and the counts it holds into ``metadata.yaml``.

        Starts the next file after it when ``split`` and the file reached its size limit.

        Raises:
            OSError: a write failed; the counts stay those on disk.
        """
        current = self._file
        assert current is not None
        saved = copy.deepcopy(current.committed), dict(self._counts), current.pending
        current.committed.merge(current.pending)
        for handle, count in current.pending.per_topic.items():
            self._counts[handle] = self._counts.get(handle, 0) + count
        current.pending = Counts()
        now = time.monotonic()
        rewrite = (
            self._metadata_interval_s is None
            or now - self._metadata_written >= self._metadata_interval_s
        )
        try:
            tmp = self._prepare_metadata(size=current.stream.tell()) if rewrite else None
            current.stream.commit()
        except OSError:
            current.committed, self._counts, current.pending = saved
            raise
        if tmp is not None:
            tmp.replace(self.path / "metadata.yaml")
            self._metadata_written = now
        if split and self._max_bytes is not None and current.stream.size >= self._max_bytes:
            self._split()

    def start_next_file(self) -> None:
        """Finish the open file now and go on in the next (``<name>_<i+1>.mcap``).

        Raises:
            RecordingWriteError: writing failed now or before (see the class doc).
            ValueError: the recording is closed.
        """
        if self.failure is not None:
            raise self.failure
        if self._file is None:
            raise ValueError(f"{self.path}: the recording is closed")
        try:
            self._split()
        except OSError as err:
            raise self._fail(err) from err

    def _split(self) -> None:
        """Close the current file and start the next."""
        self._finish_file()
        self._open_next_file()

    def _open_next_file(self) -> None:
        index = len(self._closed_files)
        path = self.path / f"{self.path.name}_{index}.mcap"
        try:
            self._file = OpenFile(path, self._chunk_bytes, self._compression)
        except OSError:  # not even a header fits: leave no file a reader would choke on
            with suppress(OSError):
                path.unlink()
            raise
        for handle, topic in enumerate(self.topics):
            self._file.add_topic(handle, topic, self._qos_texts[handle])
        self._write_metadata()

    def _finish_file(self) -> None:
        current = self._file
        assert current is not None
        if current.pending.total:  # the last chunk first: a failed summary loses no message
            current.writer.flush()  # type: ignore[no-untyped-call]
            self._commit(split=False)
        files = [*self._closed_files, current.info()]
        serialized = dump_metadata(
            bag_metadata(files, self.topics, self._counts, self._custom_data)
        )
        current.writer.add_metadata("rosbag2", {"serialized_metadata": serialized})
        current.writer.finish()  # type: ignore[no-untyped-call]
        current.stream.commit(final=True)
        self._file = None
        current.stream.close()
        self._closed_files.append(current.info())

    # -- metadata.yaml -------------------------------------------------------------------

    def files(self) -> list[FileInfo]:
        """Every file so far, with its committed messages (the open one last)."""
        return [*self._closed_files, *([self._file.info()] if self._file else [])]

    def _prepare_metadata(self, size: int | None = None) -> Path:
        files = self.files()
        if size is not None and self._file is not None:
            files[-1] = files[-1]._replace(size_bytes=size)
        document = {
            "rosbag2_bagfile_information": bag_metadata(
                files, self.topics, self._counts, self._custom_data
            )
        }
        return replace_text(self.path / "metadata.yaml", dump_metadata(document))

    def _write_metadata(self) -> None:
        self._prepare_metadata().replace(self.path / "metadata.yaml")

    def topic_counts(self) -> dict[str, int]:
        """Committed messages per topic name, every file so far."""
        return {topic.name: self._counts.get(h, 0) for h, topic in enumerate(self.topics)}

    @property
    def message_count(self) -> int:
        """Messages written so far (committed or not)."""
        pending = self._file.pending.total if self._file else 0
        return sum(self._counts.values()) + pending

    # -- closing -------------------------------------------------------------------------

    def close(self) -> None:
        """Finish the open file (summary, indexes) and write the final ``metadata.yaml``.

        After a failed write (:attr:`failure`) the open file is closed as it stands (its last
        whole chunk and a temporary footer) and ``metadata.yaml`` is rewritten when the disk
        allows; nothing is raised.

        Raises:
            RecordingWriteError: finishing failed (the recording stays as described above).
        """
        if self._file is None:
            return
        if self.failure is None:
            try:
                self._finish_file()
                self._write_metadata()
            except OSError as err:
                self._fail(err)
                if self._file is not None:
                    self._close_failed()
                raise self.failure from err  # type: ignore[misc]
            return
        self._close_failed()

    def _close_failed(self) -> None:
        """Close the open file of a failed recording as it is on disk."""
        current, self._file = self._file, None
        assert current is not None
        current.stream.close()
        self._closed_files.append(current.info())
        with suppress(OSError):
            self._write_metadata()
        with suppress(OSError):
            (self.path / "metadata.yaml.tmp").unlink(missing_ok=True)
