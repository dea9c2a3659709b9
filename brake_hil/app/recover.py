"""``brake-hil recover``: a finished copy of an unfinished MCAP recording.

A recorder killed (``kill -9``, power loss) or stopped by a full disk leaves files without
summary, a file cut inside a record, or a ``metadata.yaml`` that is missing or stale. This
command reads every whole chunk of every file in recording order
(:mod:`brake_hil.io.mcap_salvage`: python ``mcap``'s streaming reader, no seeking) and writes
the messages, byte for byte with their log and publish times, into a new rosbag2 directory
(:class:`~brake_hil.io.mcap_recorder.McapRecorder`): one finished file per input file (chunk
indexes, message indexes, statistics, summary, the ``rosbag2`` metadata record) and a
``metadata.yaml`` whose counts, start, duration and topics (type, serialisation, offered QoS,
type hash) are those of the files. ``rosbag2``'s own ``reindex`` rebuilds only
``metadata.yaml``; the copy here opens in readers that need the MCAP summary.

The input is never written to: the copy goes to a new directory.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mcap.records import Channel

from brake_hil.errors import RecordingError
from brake_hil.io.mcap_recorder import McapRecorder
from brake_hil.io.mcap_salvage import SalvagedFile, salvage_file
from brake_hil.io.unfinished import bag_metadata, offered_qos, storage_files, unfinished_reason

__all__ = ["RecoverResult", "RecoveredFile", "default_output", "run_recover"]


@dataclass(frozen=True)
class RecoveredFile:
    """One input file and what of it reached the copy.

    Attributes:
        source: the input file.
        output: the finished file written.
        finished: the input file had a summary already.
        messages: messages copied.
        lost_bytes: bytes after the last whole record (cut off or unreadable).
        stop: why reading the input stopped ("" when it was finished).
        skipped: messages left out: their channel or schema record was lost.
    """

    source: Path
    output: Path
    finished: bool
    messages: int
    lost_bytes: int
    stop: str
    skipped: int


@dataclass(frozen=True)
class RecoverResult:
    """What :func:`run_recover` wrote.

    Attributes:
        source: the input recording.
        output: the new rosbag2 directory.
        reason: why the input was unfinished; None when it was finished already.
        files: per input file, in recording order.
        topics: ``(name, type, messages)`` per topic of the copy.
    """

    source: Path
    output: Path
    reason: str | None
    files: tuple[RecoveredFile, ...]
    topics: tuple[tuple[str, str, int], ...]

    @property
    def message_count(self) -> int:
        """Messages in the copy."""
        return sum(f.messages for f in self.files)


def default_output(bag: Path) -> Path:
    """``<bag>_recovered`` beside the input (the suffix of a bare ``.mcap`` dropped)."""
    stem = bag.stem if bag.is_file() else bag.name
    return bag.parent / f"{stem}_recovered"


def _inputs(bag: Path) -> list[Path]:
    if not bag.exists():
        raise RecordingError(f"{bag}: no such file or directory")
    if bag.is_file() and bag.suffix != ".mcap":
        raise RecordingError(f"{bag}: not an MCAP file (recover reads MCAP recordings)")
    files = storage_files(bag)
    if not files:
        raise RecordingError(f"{bag}: no .mcap file to recover")
    return files


def _missing_files(bag: Path) -> str | None:
    """Files ``metadata.yaml`` lists that are not on disk (they cannot be recovered)."""
    info = bag_metadata(bag) if bag.is_dir() else None
    names = [Path(str(n)).name for n in (info or {}).get("relative_file_paths") or []]
    if missing := [n for n in names if not (bag / n).exists()]:
        return f"metadata.yaml lists {', '.join(missing)}, not on disk"
    return None


def _check_output(bag: Path, out: Path) -> None:
    if out.exists() or out.is_symlink():
        problem = "exists already; recover never overwrites, pass another --out"
        raise RecordingError(f"{out}: {problem}")
    resolved, source = out.resolve(), bag.resolve()
    if resolved == source or source in resolved.parents:
        raise RecordingError(f"{out}: inside the input {bag}; recover never writes there")


class _Copier:
    """Registers the input channels in the copy and writes their messages."""

    def __init__(self, recorder: McapRecorder) -> None:
        self.recorder = recorder
        self.handles: dict[str, tuple[str, int]] = {}  # topic -> (type, handle)

    def handle(self, salvaged: SalvagedFile, channel: Channel) -> int | None:
        schema = salvaged.schemas.get(channel.schema_id)
        if schema is None:
            return None
        if (known := self.handles.get(channel.topic)) is not None:
            return known[1] if known[0] == schema.name else None
        handle = self.recorder.add_topic(
            channel.topic,
            schema.name,
            offered_qos_profiles=offered_qos(channel),
            msgdef=schema.data.decode("utf-8", "replace"),
            type_hash=channel.metadata.get("topic_type_hash", ""),
            serialization_format=channel.message_encoding,
        )
        self.handles[channel.topic] = (schema.name, handle)
        return handle

    def copy(self, salvaged: SalvagedFile) -> tuple[int, int]:
        """Write the messages of one input file; returns (copied, skipped)."""
        handles = {cid: self.handle(salvaged, ch) for cid, ch in salvaged.channels.items()}
        copied = skipped = 0
        for message in salvaged.messages:
            handle = handles.get(message.channel_id)
            if handle is None:
                skipped += 1
                continue
            self.recorder.write(
                handle, message.log_time_ns, message.data, publish_time_ns=message.publish_time_ns
            )
            copied += 1
        return copied, skipped


def run_recover(bag: Path | str, out: Path | str | None = None) -> RecoverResult:
    """Write a finished copy of the MCAP recording ``bag`` into the new directory ``out``.

    Args:
        bag: a rosbag2 directory of ``.mcap`` files (``metadata.yaml`` present, stale or
            missing) or a bare ``.mcap`` file.
        out: the rosbag2 directory to create (default :func:`default_output`); must not exist.

    Returns:
        What was copied, per file.

    Raises:
        RecordingError: ``bag`` is missing or holds no ``.mcap``, ``out`` exists or lies inside
            ``bag``, an input file cannot be read, or not one message could be recovered.
        RecordingWriteError: writing the copy failed (it stays readable as far as written).
    """
    bag = Path(bag)
    inputs = _inputs(bag)
    target = Path(out) if out is not None else default_output(bag)
    _check_output(bag, target)
    reason = unfinished_reason(bag) or _missing_files(bag)
    info = bag_metadata(bag) if bag.is_dir() else None
    custom = {str(k): str(v) for k, v in ((info or {}).get("custom_data") or {}).items()}
    custom["recovered_from"] = str(bag)
    custom["recovered_because"] = reason or "finished already"
    files: list[RecoveredFile] = []
    try:
        salvaged_files = [salvage_file(path) for path in inputs]
    except OSError as err:
        raise RecordingError(f"{bag}: cannot read the recording: {err}") from err
    if not any(s.messages for s in salvaged_files):
        stops = "; ".join(f"{s.path.name}: {s.stop}" for s in salvaged_files if s.stop)
        raise RecordingError(
            f"{bag}: truncated or corrupt: not one whole chunk could be read ({stops})"
        )
    with McapRecorder(target, custom_data=custom) as recorder:
        copier = _Copier(recorder)
        for index, salvaged in enumerate(salvaged_files):
            if index:
                recorder.start_next_file()
            copied, skipped = copier.copy(salvaged)
            output = recorder.files()[-1].path
            files.append(
                RecoveredFile(
                    salvaged.path,
                    output,
                    salvaged.finished,
                    copied,
                    salvaged.lost_bytes,
                    salvaged.stop,
                    skipped,
                )
            )
    counts = recorder.topic_counts()
    topics = tuple((t.name, t.msgtype, counts[t.name]) for t in recorder.topics)
    return RecoverResult(bag, target, reason, tuple(files), topics)
