"""Unfinished rosbag2 MCAP recordings: tell them apart and read what their files hold.

A recording is *unfinished* when a writer did not close it (``kill -9``, power loss, a full
disk): a ``.mcap`` without summary or cut inside a record, or a rosbag2 directory whose
``metadata.yaml`` is missing, unreadable, does not list every ``.mcap`` file, or counts other
messages than the (finished) files hold. :func:`open_unfinished` reads such a recording by
streaming the whole chunks of each file (:mod:`brake_hil.io.mcap_salvage`), in the files'
recording order, and says on stderr (logger ``brake_hil.recording``, one line) that the
recording was unfinished and how many messages it recovered. What it returns answers
``topics``, ``connections`` and ``messages`` as rosbags' ``Reader`` does, so the recording
reader and every command work on what was recovered.
"""

from __future__ import annotations

from collections.abc import Collection, Iterator, Mapping, Sequence
from itertools import groupby
import logging
from pathlib import Path
import re
from typing import Any, Final

from mcap.reader import make_reader
from mcap.records import Channel
from rosbags.interfaces import (
    Connection,
    ConnectionExtRosbag2,
    MessageDefinition,
    MessageDefinitionFormat,
    Qos,
    TopicInfo,
)
from rosbags.rosbag2.metadata import parse_qos
import yaml

from brake_hil.errors import RecordingError
from brake_hil.io.mcap_salvage import MAGIC, SalvagedFile, is_finished, salvage_file

LOGGER: Final = logging.getLogger("brake_hil.recording")
"""Where the one-line note on an unfinished recording goes (stderr when unconfigured)."""

_FILE_INDEX: Final = re.compile(r"_(\d+)\.mcap$")


def _file_order(path: Path) -> tuple[int, str]:
    match = _FILE_INDEX.search(path.name)
    return (int(match.group(1)) if match else -1, path.name)


def bag_metadata(path: Path) -> dict[str, Any] | None:
    """``rosbag2_bagfile_information`` of a bag directory; None when missing or unreadable."""
    try:
        document = yaml.safe_load((path / "metadata.yaml").read_text(encoding="utf-8"))
        info = document["rosbag2_bagfile_information"]
    except (OSError, yaml.YAMLError, TypeError, KeyError, UnicodeDecodeError):
        return None
    return info if isinstance(info, dict) else None


def storage_files(path: Path, info: Mapping[str, Any] | None = None) -> list[Path]:
    """The ``.mcap`` files of a recording in recording order.

    A file is itself; for a directory the files ``metadata.yaml`` lists (those that exist),
    then any other ``.mcap`` file by its ``_<index>`` suffix. ``info``: the directory's
    metadata when read already (default: read here, :func:`bag_metadata`).
    """
    if not path.is_dir():
        return [path]
    listed: list[Path] = []
    if (info := info if info is not None else bag_metadata(path)) is not None:
        names = info.get("relative_file_paths") or []
        listed = [path / Path(str(n)).name for n in names if str(n).endswith(".mcap")]
    present = sorted(path.glob("*.mcap"), key=_file_order)
    return [p for p in listed if p.exists()] + [p for p in present if p not in listed]


def _metadata_counts(info: Mapping[str, Any]) -> dict[str, int] | None:
    try:
        return {
            str(t["topic_metadata"]["name"]): int(t["message_count"])
            for t in info["topics_with_message_count"]
        }
    except (KeyError, TypeError, ValueError):
        return None


def _summary_counts(files: Sequence[Path]) -> dict[str, int] | None:
    """Messages per topic from the files' summaries; None when one cannot be read."""
    counts: dict[str, int] = {}
    for file in files:
        try:
            with file.open("rb") as stream:
                summary = make_reader(stream).get_summary()
        except Exception:  # noqa: BLE001 - any failure: the normal reader decides
            return None
        if summary is None or summary.statistics is None:
            return None
        for channel_id, count in summary.statistics.channel_message_counts.items():
            topic = summary.channels[channel_id].topic
            counts[topic] = counts.get(topic, 0) + count
    return counts


def _starts_as_mcap(path: Path) -> bool:
    with path.open("rb") as stream:
        return stream.read(len(MAGIC)) == MAGIC


def unfinished_reason(path: Path, info: Mapping[str, Any] | None = None) -> str | None:
    """Why a recording counts as unfinished (see the module doc); None when it does not.

    Only MCAP storage is judged: a ``.db3`` file or an sqlite3 bag is never unfinished here,
    and a directory whose ``metadata.yaml`` lists a missing file is left to the normal reader
    (it refuses it). ``info``: the directory's metadata when read already (default: read
    here, :func:`bag_metadata`).
    """
    if path.is_file():
        if path.suffix != ".mcap" or not _starts_as_mcap(path):
            return None  # not an MCAP at all: the normal reader refuses it
        return None if is_finished(path) else "the file has no summary or ends inside a record"
    mcaps = sorted(path.glob("*.mcap"), key=_file_order)
    if not mcaps:
        return None
    if not (path / "metadata.yaml").exists():
        return "no metadata.yaml"
    if (info := info if info is not None else bag_metadata(path)) is None:
        return "metadata.yaml is unreadable"
    if info.get("storage_identifier", "mcap") != "mcap":
        return None
    listed = {Path(str(n)).name for n in info.get("relative_file_paths") or []}
    if any(not (path / name).exists() for name in listed):
        return None
    if unlisted := [p.name for p in mcaps if p.name not in listed]:
        return f"metadata.yaml does not list {', '.join(unlisted)}"
    if cut := [p.name for p in mcaps if not is_finished(p)]:
        return f"{', '.join(cut)} not finished (no summary, or cut)"
    declared, held = _metadata_counts(info), _summary_counts(mcaps)
    nonzero = {topic: n for topic, n in (declared or {}).items() if n}
    if declared is not None and held is not None and nonzero != held:
        return (
            f"metadata.yaml counts {sum(declared.values())} messages, "
            f"the files hold {sum(held.values())}"
        )
    return None


def offered_qos(channel: Channel) -> list[Qos]:
    """A rosbag2 MCAP channel's ``offered_qos_profiles``; [] when absent or unreadable."""
    text = channel.metadata.get("offered_qos_profiles", "")
    try:
        return list(parse_qos(yaml.safe_load(text) or [])) if text else []
    except (yaml.YAMLError, KeyError, TypeError, ValueError, AttributeError):
        return []


def _connection_key(salvaged: SalvagedFile, channel_id: int) -> tuple[str, str, str, str, str]:
    channel = salvaged.channels[channel_id]
    schema = salvaged.schemas.get(channel.schema_id)
    return (
        channel.topic,
        schema.name if schema else "",
        channel.message_encoding,
        channel.metadata.get("offered_qos_profiles", ""),
        channel.metadata.get("topic_type_hash", ""),
    )


class SalvagedRecording:
    """The messages recovered from an unfinished recording, as rosbags' ``Reader`` offers them.

    Args:
        path: the recording (directory or ``.mcap``).
        files: what :func:`~brake_hil.io.mcap_salvage.salvage_file` read from each file, in
            recording order.
        reason: why the recording counts as unfinished.
    """

    def __init__(self, path: Path, files: Sequence[SalvagedFile], reason: str) -> None:
        self.path = path
        self.files = list(files)
        self.reason = reason
        self.connections: list[Connection] = []
        keys: dict[tuple[str, str, str, str, str], int] = {}
        counts: dict[int, int] = {}
        self._rows: list[tuple[int, int, bytes]] = []  # (connection index, log time, data)
        for salvaged in self.files:
            index_of: dict[int, int] = {}
            for channel_id in salvaged.channels:
                key = _connection_key(salvaged, channel_id)
                if key not in keys:
                    keys[key] = len(keys)
                    self.connections.append(self._connection(salvaged, channel_id, len(keys)))
                index_of[channel_id] = keys[key]
            for message in salvaged.messages:
                if (index := index_of.get(message.channel_id)) is None:
                    continue  # a message of a channel whose record was lost: unusable
                counts[index] = counts.get(index, 0) + 1
                self._rows.append((index, message.log_time_ns, message.data))
        self._rows.sort(key=lambda row: row[1])
        self.connections = [
            c._replace(msgcount=counts.get(i, 0)) for i, c in enumerate(self.connections)
        ]

    def _connection(self, salvaged: SalvagedFile, channel_id: int, number: int) -> Connection:
        channel = salvaged.channels[channel_id]
        schema = salvaged.schemas.get(channel.schema_id)
        qos = offered_qos(channel)
        msgdef = (
            MessageDefinition(MessageDefinitionFormat.MSG, schema.data.decode("utf-8", "replace"))
            if schema is not None and schema.encoding == "ros2msg"
            else MessageDefinition(MessageDefinitionFormat.NONE, "")
        )
        return Connection(
            id=number,
            topic=channel.topic,
            msgtype=schema.name if schema is not None else "",
            msgdef=msgdef,
            digest=channel.metadata.get("topic_type_hash", ""),
            msgcount=0,
            ext=ConnectionExtRosbag2(channel.message_encoding, qos),
            owner=self,
        )

    @property
    def message_count(self) -> int:
        """Messages recovered."""
        return len(self._rows)

    @property
    def topics(self) -> dict[str, TopicInfo]:
        """Topic information, as rosbags' ``Reader.topics``."""
        topics: dict[str, TopicInfo] = {}
        ordered = sorted(self.connections, key=lambda c: c.topic)
        for topic, group in groupby(ordered, key=lambda c: c.topic):
            connections = list(group)
            msgtypes = {c.msgtype for c in connections}
            msgdefs = {c.msgdef for c in connections}
            topics[topic] = TopicInfo(
                msgtypes.pop() if len(msgtypes) == 1 else None,
                msgdefs.pop()
                if len(msgdefs) == 1
                else MessageDefinition(MessageDefinitionFormat.NONE, ""),
                sum(c.msgcount for c in connections),
                connections,
            )
        return topics

    def messages(
        self, connections: Collection[Connection] = ()
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """``(connection, log time (ns), CDR bytes)`` in log-time order, as rosbags yields."""
        wanted = {c.id for c in connections} if connections else None
        for index, log_time, data in self._rows:
            connection = self.connections[index]
            if wanted is None or connection.id in wanted:
                yield connection, log_time, data

    def close(self) -> None:
        """Nothing to release (the messages are in memory)."""

    def note(self) -> str:
        """One line: the recording was unfinished, what was recovered, what was lost."""
        details = []
        for salvaged in self.files:
            if salvaged.stop and salvaged.stop != "a footer without summary":
                details.append(
                    f"{salvaged.path.name}: {len(salvaged.messages)} messages, "
                    f"{salvaged.stop} of {salvaged.size_bytes}"
                )
        plural = "s" if len(self.files) != 1 else ""
        return (
            f"{self.path}: unfinished recording ({self.reason}): recovered "
            f"{self.message_count} messages from the whole chunks of {len(self.files)} "
            f"file{plural}"
            + (f" ({'; '.join(details)})" if details else "")
            + f"; `brake-hil recover {self.path}` writes a finished copy"
        )


def salvage_recording(
    path: Path, reason: str, info: Mapping[str, Any] | None = None
) -> SalvagedRecording:
    """Read every whole chunk of every ``.mcap`` file of ``path`` (``info``: its metadata).

    Raises:
        RecordingError: a file cannot be read, or not one message could be recovered.
    """
    try:
        files = [salvage_file(file) for file in storage_files(path, info)]
    except OSError as err:
        raise RecordingError(f"{path}: cannot read the recording: {err}") from err
    recording = SalvagedRecording(path, files, reason)
    if recording.message_count == 0:
        stops = "; ".join(f"{f.path.name}: {f.stop}" for f in files if f.stop)
        raise RecordingError(
            f"{path}: unfinished recording ({reason}), truncated or corrupt: not one whole "
            f"chunk could be read ({stops or 'no messages'})"
        )
    return recording


def open_unfinished(path: Path, info: Mapping[str, Any] | None = None) -> SalvagedRecording | None:
    """The recovered messages of an unfinished recording, None when ``path`` is finished.

    ``info`` is the directory's ``metadata.yaml`` when the caller has read it already
    (:func:`~brake_hil.io.recording_checks.check_recording_path`); default: read here.

    Logs one line on ``brake_hil.recording`` (stderr when logging is not configured): the
    recording was unfinished, how many messages were recovered, what was cut; the record's
    ``brief`` says it in a few words (``brake-hil`` adds it to a refusal's one line).

    Raises:
        RecordingError: unfinished and nothing could be recovered, or unreadable.
    """
    try:
        reason = unfinished_reason(path, info)
    except OSError as err:
        raise RecordingError(f"{path}: cannot read the recording: {err}") from err
    if reason is None:
        return None
    recording = salvage_recording(path, reason, info)
    brief = (
        f"read from an unfinished recording: {recording.message_count} messages recovered "
        "from its whole chunks"
    )
    LOGGER.warning(recording.note(), extra={"brief": brief})
    return recording
