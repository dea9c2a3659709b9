"""Write rig recordings as rosbag2 MCAP directories, as ``ros2 bag record -s mcap`` does.

The directory holds ``metadata.yaml`` (rosbag2 version 9, the Kilted format), written by
rosbags' rosbag2 ``Writer``, and one ``<name>_0.mcap``: profile ``ros2``, one ``ros2msg``
schema per type, channels carrying ``offered_qos_profiles`` and ``topic_type_hash``, CDR
messages in zstd-compressed chunks with CRCs (libmcap's defaults, so a corrupt chunk is
detected on reading), indexes, statistics and the ``rosbag2`` metadata record. The ``.mcap``
is written by the ``mcap`` package through rosbags' storage-plugin interface, because rosbags'
own MCAP storage writes no CRCs. Messages are serialised in bulk by
:mod:`brake_hil.io.stamped_cdr`; ``header.stamp`` is the sample time and the log time equals
it unless given (a recorder logs the receive time).
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache
from pathlib import Path
from types import MappingProxyType
from typing import Final, NamedTuple

from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter
import numpy as np
from rosbags.interfaces import (
    Connection,
    MessageDefinitionFormat,
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import CompressionMode, StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from brake_hil import __version__
from brake_hil.analysis.recording import Recording
from brake_hil.io.recording_reader import RECORDING_FIELDS
from brake_hil.io.stamped_cdr import encode_stamped
from brake_hil.topics import TopicSpec
from brake_hil.types import FloatArray, IntArray

DEFAULT_START_STAMP_NS: Final = 1_700_000_000_000_000_000
"""Stamp of the first sample when none is given (ns since the epoch, 2023-11-14T22:13:20Z)."""
DEFAULT_FRAME_ID: Final = "caliper"
"""``header.frame_id`` of every message unless given."""

_INFINITE = QosTime(sec=9223372036, nsec=854775807)  # rmw's "infinite" duration
_DEFAULT_QOS: Final = Qos(  # rclcpp's default publisher QoS: reliable, volatile, keep last 10
    history=QosHistory.KEEP_LAST,
    depth=10,
    reliability=QosReliability.RELIABLE,
    durability=QosDurability.VOLATILE,
    deadline=_INFINITE,
    lifespan=_INFINITE,
    liveliness=QosLiveliness.AUTOMATIC,
    liveliness_lease_duration=_INFINITE,
    avoid_ros_namespace_conventions=False,
)


class _McapStorage:
    """rosbags storage plugin that writes the ``.mcap`` with the ``mcap`` package."""

    def __init__(self, path: Path, compression: CompressionMode) -> None:
        del compression  # chunks are always zstd-compressed; the bag itself is not
        self.path = path / f"{path.name}_0.mcap"
        self._stream = self.path.open("xb")
        self._mcap = McapWriter(self._stream, compression=CompressionType.ZSTD, enable_crcs=True)
        self._mcap.start(profile="ros2", library=f"brake_hil {__version__}")
        self._schema_ids: dict[str, int] = {}
        self._channel_ids: dict[int, int] = {}

    def add_msgtype(self, connection: Connection) -> None:
        """Register the schema of ``connection``'s type."""
        is_msg = connection.msgdef.format == MessageDefinitionFormat.MSG
        self._schema_ids[connection.msgtype] = self._mcap.register_schema(
            connection.msgtype, "ros2msg" if is_msg else "ros2idl", connection.msgdef.data.encode()
        )

    def add_connection(self, connection: Connection, offered_qos_profiles: str) -> None:
        """Register a channel for ``connection``'s topic."""
        self._channel_ids[connection.id] = self._mcap.register_channel(
            connection.topic,
            "cdr",
            self._schema_ids[connection.msgtype],
            {"offered_qos_profiles": offered_qos_profiles, "topic_type_hash": connection.digest},
        )

    def write(self, connection: Connection, timestamp: int, data: bytes | memoryview) -> None:
        """Write one message; ``timestamp`` (ns) is its log and publish time."""
        self._mcap.add_message(self._channel_ids[connection.id], timestamp, bytes(data), timestamp)

    def close(self, version: int, metadata: str) -> None:
        """Finish the file: the ``rosbag2`` metadata record, summary and footer."""
        del version
        self._mcap.add_metadata("rosbag2", {"serialized_metadata": metadata})
        self._mcap.finish()  # type: ignore[no-untyped-call]
        self._stream.close()

    def abort(self) -> None:
        """Close without a summary (the file is left truncated)."""
        self._stream.close()


class _Rosbag2Writer(Writer):
    """rosbags' rosbag2 writer with :class:`_McapStorage` for MCAP."""

    STORAGE_PLUGINS = MappingProxyType(
        {**Writer.STORAGE_PLUGINS, StoragePlugin.MCAP: _McapStorage}
    )


class TopicSeries(NamedTuple):
    """Samples of one topic to write."""

    stamps_ns: IntArray  # header.stamp of each sample (ns since the epoch)
    values: FloatArray  # the topic's field (SI units)
    log_times_ns: IntArray | None = None  # when each sample was logged (ns); None: the stamps
    # Readers return messages in log-time order; to record a rig clock that jumps back,
    # give log times that run on while the stamps go back.


@lru_cache(maxsize=1)
def _typestore() -> Typestore:
    """Kilted's message definitions, for the schemas and type hashes (loaded once)."""
    return get_typestore(Stores.ROS2_KILTED)


def _checked(spec: TopicSpec, series: TopicSeries) -> tuple[IntArray, FloatArray, IntArray]:
    """Stamps (ns), values and log times (ns) of ``series`` as 1-D arrays of one length."""
    stamps = np.asarray(series.stamps_ns, dtype=np.int64)
    values = np.asarray(series.values, dtype=np.float64)
    logged = stamps if series.log_times_ns is None else np.asarray(series.log_times_ns, np.int64)
    if stamps.ndim != 1 or values.shape != stamps.shape or logged.shape != stamps.shape:
        msg = (
            f"{spec.name}: stamps {stamps.shape}, values {values.shape} and log times "
            f"{logged.shape} must be 1-D of one length"
        )
        raise ValueError(msg)
    if stamps.size and logged.min() < 0:
        raise ValueError(f"{spec.name}: log times must not be negative")
    if series.log_times_ns is None and (back := np.flatnonzero(np.diff(stamps) < 0)).size:
        msg = (
            f"{spec.name}: stamps go backwards at sample {back[0] + 1}; messages are stored in "
            "log-time order, so give log_times_ns to record them as they were logged"
        )
        raise ValueError(msg)
    return stamps, values, logged


def write_topics(
    path: Path | str,
    series: Mapping[TopicSpec, TopicSeries],
    *,
    frame_id: str = DEFAULT_FRAME_ID,
) -> Path:
    """Write samples of contract topics as a new rosbag2 MCAP directory.

    Messages are written in log-time order (stable across topics, in the order of
    ``series``). Values are written as given, NaN included: checks belong to the reader.

    Args:
        path: the directory to create; must not exist.
        series: samples per topic; each topic's type is its spec's ``msgtype``.
        frame_id: ``header.frame_id`` of every message.

    Returns:
        ``path`` as a Path.

    Raises:
        FileExistsError: ``path`` exists (nothing is overwritten).
        ValueError: arrays of different lengths, an unsupported type or field, a stamp
            outside ``builtin_interfaces/msg/Time``, a negative log time, stamps going
            backwards without log times (they would be stored sorted, hiding the jump).
    """
    path = Path(path)
    if path.exists():
        raise FileExistsError(f"{path}: exists already, not overwriting a recording")
    specs = list(series)
    encoded, log_times, topic_index = [], [], []
    for number, spec in enumerate(specs):
        stamps, values, logged = _checked(spec, series[spec])
        encoded.append(encode_stamped(spec.msgtype, spec.field, stamps, values, frame_id))
        log_times.append(logged)
        topic_index.append(np.full(stamps.size, number, dtype=np.int64))
    all_log_times = np.concatenate(log_times) if specs else np.zeros(0, np.int64)
    all_topics = np.concatenate(topic_index) if specs else np.zeros(0, np.int64)
    order = np.argsort(all_log_times, kind="stable")  # messages in log-time order
    offsets = np.cumsum([0, *(len(e) for e in encoded)])
    rows = np.arange(all_topics.size) - offsets[all_topics]  # message index within its topic
    blobs = [e.tobytes() for e in encoded]
    sizes = [e.shape[1] for e in encoded]

    typestore = _typestore()
    with _Rosbag2Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = [
            writer.add_connection(
                spec.name, spec.msgtype, typestore=typestore, offered_qos_profiles=[_DEFAULT_QOS]
            )
            for spec in specs
        ]
        write = writer.write
        for topic, row, log_time in zip(
            all_topics[order].tolist(), rows[order].tolist(), all_log_times[order].tolist()
        ):
            size = sizes[topic]
            write(connections[topic], log_time, blobs[topic][row * size : (row + 1) * size])
    return path


def write_recording(
    path: Path | str,
    time: FloatArray,
    channels: Mapping[TopicSpec, FloatArray],
    *,
    start_stamp_ns: int = DEFAULT_START_STAMP_NS,
    frame_id: str = DEFAULT_FRAME_ID,
) -> Path:
    """Write channels sampled at common times as a new rosbag2 MCAP directory.

    Args:
        path: the directory to create; must not exist.
        time: sample times (s) relative to ``start_stamp_ns``, shared by every channel.
        channels: values per topic (SI units), each as long as ``time``.
        start_stamp_ns: stamp of ``time == 0`` (ns since the epoch).
        frame_id: ``header.frame_id`` of every message.

    Returns:
        ``path`` as a Path.

    Raises:
        FileExistsError: ``path`` exists.
        ValueError: a channel's length differs from ``time``'s, or as :func:`write_topics`.
    """
    time = np.asarray(time, dtype=np.float64)
    if time.ndim != 1 or not np.all(np.isfinite(time)):
        raise ValueError(f"time must be 1-D and finite, got shape {time.shape}")
    stamps = np.int64(start_stamp_ns) + np.round(time * 1e9).astype(np.int64)
    return write_topics(
        path,
        {spec: TopicSeries(stamps, np.asarray(v, np.float64)) for spec, v in channels.items()},
        frame_id=frame_id,
    )


def recording_channels(recording: Recording) -> dict[TopicSpec, FloatArray]:
    """The channels a :class:`Recording` holds, keyed by contract topic (absent ones left out)."""
    channels: dict[TopicSpec, FloatArray] = {}
    for spec, attribute in RECORDING_FIELDS.items():
        values: FloatArray | None = getattr(recording, attribute)
        if values is not None:
            channels[spec] = values
    return channels


def save_recording(
    path: Path | str, recording: Recording, *, frame_id: str = DEFAULT_FRAME_ID
) -> Path:
    """Write a :class:`Recording` (its channels on its stamps) as a new rosbag2 MCAP directory.

    Reading the result with :func:`~brake_hil.io.recording_reader.read_recording` gives the
    same arrays and ``start_stamp_ns``.
    """
    return write_recording(
        path,
        recording.time,
        recording_channels(recording),
        start_stamp_ns=recording.start_stamp_ns,
        frame_id=frame_id,
    )
