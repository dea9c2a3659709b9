"""Read a rig recording into a :class:`~brake_hil.analysis.recording.Recording`.

Accepted (docs/interface.md, "Recordings"): a rosbag2 directory (``metadata.yaml`` with one or
more ``.mcap`` or ``.db3`` files), a bare ``.mcap`` file and a bare ``.db3`` file. rosbags'
``Reader`` yields raw CDR bytes, so only the brake topics are decoded, by
:mod:`brake_hil.io.stamped_cdr`; unrelated topics, unknown types and service events are
listed but never deserialised. An unfinished MCAP recording (a writer killed, a full disk:
no summary, a cut file, ``metadata.yaml`` missing or stale) is read from the whole chunks of
its files, with one line on stderr saying so (:mod:`brake_hil.io.unfinished`).

Every value carries its ``header.stamp``, not its log time. Channels are aligned to the
stamps of ``/brake/master_cylinder/pressure`` (``p_i``): copied where the stamps coincide,
linearly interpolated between neighbouring samples otherwise. When channels start or end at
different stamps (a recorder subscribes to each topic as it discovers it), the recording is
cut to the span every channel covers; a channel with no overlap at all is refused.

Every problem with the input is a :class:`~brake_hil.errors.RecordingError` whose one-line
message starts with the path; the library's exception is chained as the cause.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
import errno
import os
from pathlib import Path
from typing import Final, NamedTuple, cast

import numpy as np
from rosbags.interfaces import Connection
from rosbags.rosbag2 import Reader

from brake_hil.analysis.recording import Recording
from brake_hil.errors import MissingTopicError, RecordingError
from brake_hil.io.recording_checks import check_channel, check_recording_path, unsupported_format
from brake_hil.io.stamped_cdr import decode_stamped
from brake_hil.io.unfinished import open_unfinished
from brake_hil.topics import (
    AIR_PRESSURE,
    BLOCK_FORCE,
    BORE_PRESSURE,
    CALIPER_DISPLACEMENT,
    MASTER_CYLINDER_PRESSURE,
    PREDICTED_BLOCK_FORCE,
    PREDICTED_BORE_PRESSURE,
    PREDICTED_CALIPER_DISPLACEMENT,
    TopicSpec,
)
from brake_hil.types import FloatArray, IntArray

RECORDING_FIELDS: Final[Mapping[TopicSpec, str]] = {
    MASTER_CYLINDER_PRESSURE: "master_cylinder_pressure",
    BORE_PRESSURE: "bore_pressure",
    BLOCK_FORCE: "block_force",
    CALIPER_DISPLACEMENT: "caliper_displacement",
    AIR_PRESSURE: "air_pressure",
    PREDICTED_BORE_PRESSURE: "predicted_bore_pressure",
    PREDICTED_BLOCK_FORCE: "predicted_block_force",
    PREDICTED_CALIPER_DISPLACEMENT: "predicted_caliper_displacement",
}
"""The :class:`Recording` attribute each contract topic fills."""

_BAG_SUFFIXES: Final = (".mcap", ".db3")


class TopicSummary(NamedTuple):
    """One topic of a recording, as ``ros2 bag info`` lists it."""

    name: str
    msgtype: str  # ROS 2 type name; "" when the topic's connections disagree
    message_count: int


class _Channel(NamedTuple):
    """One topic's samples, in recorded order."""

    stamps_ns: IntArray  # header.stamp (ns since the epoch)
    values: FloatArray  # SI units


def _fail(path: Path, problem: str) -> RecordingError:
    return RecordingError(f"{path}: {problem}")


def _count(number: int, noun: str) -> str:
    return f"{number} {noun}{'' if number == 1 else 's'}"


def _one_line(err: BaseException) -> str:
    text = " ".join(str(err).split()) or type(err).__name__
    return text.rstrip(".")


def _check_path(path: Path) -> Mapping[str, object] | None:
    """Refuse a path that cannot hold a recording, before any library sees it.

    Returns:
        The bag folder's metadata (:func:`~brake_hil.io.recording_checks.check_recording_path`).
    """
    info = check_recording_path(path)
    if not path.exists():
        missing = FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), str(path))
        raise _fail(path, "no such file or directory") from missing
    if path.is_dir():
        if (path / "metadata.yaml").is_file() or any(path.glob("*.mcap")):
            return info  # without metadata.yaml: an unfinished recording (io.unfinished)
        found = sorted(p.name for p in path.iterdir() if p.suffix in _BAG_SUFFIXES)
        hint = f"; pass the storage file itself ({', '.join(found)})" if found else ""
        raise _fail(path, f"not a rosbag2 directory: no metadata.yaml{hint}")
    if path.suffix not in _BAG_SUFFIXES:
        raise _fail(path, "not a recording: expected a rosbag2 directory, a .mcap or a .db3 file")
    return info


def _open(path: Path) -> Reader:
    """An open rosbags reader of ``path``; every library error becomes a RecordingError.

    An unfinished MCAP recording is read by streaming its whole chunks instead
    (:func:`~brake_hil.io.unfinished.open_unfinished`, one line on stderr).
    """
    info = _check_path(path)
    if (salvaged := open_unfinished(path, info)) is not None:
        return cast(Reader, salvaged)  # answers topics, messages and close as Reader does
    try:
        reader = Reader(path)
        reader.open()
    except Exception as err:  # rosbags, sqlite3, zstd and lz4 raise many types on bad input
        raise _unreadable(path, err) from err
    return reader


def _unreadable(path: Path, err: Exception) -> RecordingError:
    if isinstance(err, OSError):
        return _fail(path, f"cannot read the recording: {_one_line(err)}")
    if (problem := unsupported_format(path)) is not None:
        return _fail(path, problem)
    return _fail(path, f"unreadable recording (truncated or corrupt?): {_one_line(err)}")


def _summaries(reader: Reader) -> list[TopicSummary]:
    return [
        TopicSummary(name, info.msgtype or "", info.msgcount)
        for name, info in sorted(reader.topics.items())
    ]


def list_topics(path: Path | str) -> list[TopicSummary]:
    """Every topic of a recording with its type and message count, sorted by name.

    Raises:
        RecordingError: the path is missing, not a recording, or unreadable.
    """
    path = Path(path)
    reader = _open(path)
    try:
        return _summaries(reader)
    finally:
        reader.close()


def _describe(topics: Sequence[TopicSummary]) -> str:
    if not topics:
        return "no topics"
    return ", ".join(
        f"{t.name} ({t.msgtype}, {_count(t.message_count, 'message')})" for t in topics
    )


def _select(
    path: Path, reader: Reader, required: Sequence[TopicSpec]
) -> dict[TopicSpec, list[Connection]]:
    """Connections of the contract topics present; refuse missing or mistyped ones."""
    topics = reader.topics
    if missing := [name for name in dict.fromkeys(s.name for s in required) if name not in topics]:
        listing = _describe(_summaries(reader))
        msg = f"{path}: missing topic {', '.join(missing)}; the recording holds {listing}"
        raise MissingTopicError(msg)
    selected: dict[TopicSpec, list[Connection]] = {}
    for spec in RECORDING_FIELDS:
        if (info := topics.get(spec.name)) is None:
            continue
        types = sorted({c.msgtype for c in info.connections})
        if types != [spec.msgtype]:
            raise _fail(path, f"topic {spec.name} has type {', '.join(types)}, not {spec.msgtype}")
        formats = {getattr(c.ext, "serialization_format", "cdr") for c in info.connections}
        if formats != {"cdr"}:
            problem = f"topic {spec.name} is serialised as {', '.join(sorted(formats))}, not cdr"
            raise _fail(path, problem)
        selected[spec] = info.connections
    return selected


def _raw_messages(
    path: Path, reader: Reader, selected: Mapping[TopicSpec, list[Connection]]
) -> dict[TopicSpec, list[bytes]]:
    """Serialised messages of each selected topic, in log-time order, all that are declared."""
    raw: dict[str, list[bytes]] = {spec.name: [] for spec in selected}
    connections = [conn for conns in selected.values() for conn in conns]
    try:
        for conn, _log_time, data in reader.messages(connections=connections):
            raw[conn.topic].append(data)
    except Exception as err:  # a corrupt chunk surfaces only while iterating
        raise _unreadable(path, err) from err
    for spec, conns in selected.items():
        declared, found = sum(c.msgcount for c in conns), len(raw[spec.name])
        if found != declared:
            problem = (
                f"topic {spec.name}: the file declares {declared} messages but {found} could "
                "be read (truncated or corrupt?)"
            )
            raise _fail(path, problem)
    return {spec: raw[spec.name] for spec in selected}


def _decode(path: Path, spec: TopicSpec, messages: Sequence[bytes]) -> _Channel:
    """Decode one topic and check its samples: at least 2, finite, stamps increasing."""
    try:
        stamps, values = decode_stamped(spec.msgtype, spec.field, messages)
    except ValueError as err:
        raise _fail(path, f"topic {spec.name}: corrupt message: {_one_line(err)}") from err
    if stamps.size < 2:
        problem = f"topic {spec.name} has {_count(stamps.size, 'sample')}, at least 2 are needed"
        raise _fail(path, problem)
    if (bad := np.flatnonzero(~np.isfinite(values))).size:
        problem = (
            f"topic {spec.name} has {_count(bad.size, 'NaN/inf sample')} of {values.size}, "
            f"the first at sample {bad[0]} (stamp {stamps[bad[0]]} ns)"
        )
        raise _fail(path, problem)
    steps = np.diff(stamps)
    if (back := np.flatnonzero(steps < 0)).size:
        i = int(back[0]) + 1
        problem = (
            f"stamps of topic {spec.name} go backwards at sample {i} of {stamps.size}: "
            f"{stamps[i]} ns after {stamps[i - 1]} ns ({_count(back.size, 'time')} in all)"
        )
        raise _fail(path, problem)
    if (repeat := np.flatnonzero(steps == 0)).size:
        i = int(repeat[0]) + 1
        problem = (
            f"stamps of topic {spec.name} repeat at sample {i} of {stamps.size}: "
            f"{stamps[i]} ns ({_count(repeat.size, 'time')} in all)"
        )
        raise _fail(path, problem)
    check_channel(path, spec, stamps, values)
    return _Channel(stamps, values)


def _common_span(path: Path, channels: Mapping[TopicSpec, _Channel]) -> tuple[int, int]:
    """First and last stamp (ns) every channel covers; refuse a channel outside p_i's span."""
    base = channels[MASTER_CYLINDER_PRESSURE].stamps_ns
    first, last = int(base[0]), int(base[-1])
    for spec, channel in channels.items():
        start, end = int(channel.stamps_ns[0]), int(channel.stamps_ns[-1])
        if start > base[-1] or end < base[0]:
            problem = (
                f"topic {spec.name} ({start}..{end} ns) does not overlap "
                f"{MASTER_CYLINDER_PRESSURE.name} ({base[0]}..{base[-1]} ns)"
            )
            raise _fail(path, problem)
        first, last = max(first, start), min(last, end)
    return first, last


def _align(target: IntArray, channel: _Channel) -> FloatArray:
    """``channel`` at the stamps ``target`` (inside its span): exact or linear."""
    stamps, values = channel
    if stamps.shape == target.shape and np.array_equal(stamps, target):
        return values
    origin = target[0]
    aligned: FloatArray = np.interp(
        (target - origin).astype(np.float64), (stamps - origin).astype(np.float64), values
    )
    index = np.minimum(np.searchsorted(stamps, target), stamps.size - 1)
    exact = stamps[index] == target
    aligned[exact] = values[index[exact]]
    return aligned


def read_recording(
    path: Path | str, required: Sequence[TopicSpec] = (MASTER_CYLINDER_PRESSURE,)
) -> Recording:
    """Read a recording's contract topics, aligned to the master-cylinder pressure's stamps.

    Args:
        path: a rosbag2 directory (MCAP or sqlite3, one or more files), a ``.mcap`` or a
            ``.db3`` file.
        required: topics that must be present. ``p_i`` is always needed (it is the time
            base); the other contract topics are read when present and are ``None`` when
            absent or without messages.

    Returns:
        The recording; ``time`` (s) counts from the first ``p_i`` sample of the span all
        present channels cover, ``start_stamp_ns`` is that sample's stamp (ns), ``topics``
        lists every topic the file holds.

    Raises:
        MissingTopicError: a required topic is absent (the message lists those present).
        RecordingError: missing path, not a recording, truncated or corrupt file, a topic of
            the wrong type, fewer than 2 samples, NaN/inf samples, stamps going backwards or
            repeating, or a channel that does not overlap ``p_i`` in time; or refused at the
            door (:mod:`brake_hil.io.recording_checks`): not a regular file or folder, too
            large, outside its physical bounds, too slow a sample rate, or a gap.
    """
    path = Path(path)
    unknown = [spec.name for spec in required if spec not in RECORDING_FIELDS]
    if unknown:
        msg = f"required topics {unknown} are not contract topics a Recording can hold"
        raise ValueError(msg)
    needed = (MASTER_CYLINDER_PRESSURE, *required)
    reader = _open(path)
    try:
        selected = _select(path, reader, needed)
        raw = _raw_messages(path, reader, selected)
        topics = tuple(sorted(reader.topics))
    finally:
        reader.close()
    channels = {
        spec: _decode(path, spec, messages)
        for spec, messages in raw.items()
        if messages or spec in needed  # an optional topic without messages counts as absent
    }

    first, last = _common_span(path, channels)
    base = channels[MASTER_CYLINDER_PRESSURE].stamps_ns
    keep = (base >= first) & (base <= last)
    target = base[keep]
    if target.size < 2:
        problem = (
            f"the channels overlap over {_count(target.size, 'sample')} of "
            f"{MASTER_CYLINDER_PRESSURE.name} ({first}..{last} ns), at least 2 are needed"
        )
        raise _fail(path, problem)
    aligned = {spec: _align(target, channel) for spec, channel in channels.items()}
    return Recording(
        path=path,
        time=(target - target[0]).astype(np.float64) / 1e9,
        master_cylinder_pressure=aligned[MASTER_CYLINDER_PRESSURE],
        bore_pressure=aligned.get(BORE_PRESSURE),
        block_force=aligned.get(BLOCK_FORCE),
        caliper_displacement=aligned.get(CALIPER_DISPLACEMENT),
        air_pressure=aligned.get(AIR_PRESSURE),
        predicted_bore_pressure=aligned.get(PREDICTED_BORE_PRESSURE),
        predicted_block_force=aligned.get(PREDICTED_BLOCK_FORCE),
        predicted_caliper_displacement=aligned.get(PREDICTED_CALIPER_DISPLACEMENT),
        start_stamp_ns=int(target[0]),
        topics=topics,
    )
