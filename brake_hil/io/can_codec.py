"""The rig's CAN frames: the DBC codec with its length and CRC checks (ROS-free).

Each rig frame (``config/brake_rig.dbc``) carries 16-bit sensor counts, a 24-bit
``sample_counter`` shared by the frames of one acquisition and a ``crc8`` (CRC-8/SAE-J1850
over the frame id and data bytes 0-6) in byte 7. :class:`RigFrameCodec` encodes an
acquisition's frames and decodes one frame, refusing a bad one
(:class:`~brake_hil.errors.FrameError`).
"""

from __future__ import annotations

from collections.abc import Mapping
import math
from pathlib import Path
import sys
from typing import Any, Final, NamedTuple

import can
import cantools

from brake_hil.errors import ChecksumError, DbcError, FrameLengthError, UnknownFrameError

__all__ = [
    "COUNTER_MODULUS",
    "COUNTER_SIGNAL",
    "CRC_SIGNAL",
    "DEFAULT_DBC_PATH",
    "DecodedFrame",
    "FrameSpec",
    "RigFrameCodec",
    "crc8_sae_j1850",
    "default_dbc_path",
    "frame_crc",
]

DEFAULT_DBC_PATH: Final = Path(__file__).resolve().parents[2] / "config" / "brake_rig.dbc"
"""The rig's CAN database in a source checkout (see :func:`default_dbc_path`)."""

COUNTER_SIGNAL: Final = "sample_counter"
CRC_SIGNAL: Final = "crc8"
COUNTER_MODULUS: Final = 1 << 24
_CRC_BYTE: Final = 7


def default_dbc_path() -> Path:
    """``config/brake_rig.dbc`` of the checkout, else of the ament install (``share/``)."""
    if DEFAULT_DBC_PATH.is_file():
        return DEFAULT_DBC_PATH
    return Path(sys.prefix) / "share" / "brake_hil" / "config" / "brake_rig.dbc"


def crc8_sae_j1850(data: bytes | bytearray) -> int:
    """CRC-8/SAE-J1850: poly 0x1D, init 0xFF, no reflection, xorout 0xFF (check 0x4B)."""
    crc = 0xFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc ^ 0xFF


def frame_crc(arbitration_id: int, data: bytes | bytearray) -> int:
    """The rig's crc8 of a frame: over the id, then data bytes 0-6.

    The id takes 2 little-endian bytes, 4 if extended.
    """
    width = 2 if arbitration_id < 0x800 else 4
    return crc8_sae_j1850(arbitration_id.to_bytes(width, "little") + bytes(data[:_CRC_BYTE]))


class FrameSpec(NamedTuple):
    """One rig frame of the DBC."""

    name: str  # DBC message name
    frame_id: int
    is_extended: bool
    quantities: tuple[str, ...]  # the signals that carry measurements, e.g. ("p_i", "p_b")


class DecodedFrame(NamedTuple):
    """The content of one good frame."""

    name: str
    counter: int  # raw sample_counter, 0 .. 2**24 - 1
    values: dict[str, float]  # quantity -> SI value (Pa, N, m)


class _Signal(NamedTuple):
    low: float  # SI value of raw 0 (the DBC offset)
    scale: float  # SI per count
    top: int  # largest raw count


class RigFrameCodec:
    """Encode and decode the rig's frames with a DBC (cantools), checking length and CRC.

    Args:
        dbc_path: the CAN database; every message in it must be 8 bytes long, carry
            ``sample_counter`` and ``crc8`` (byte 7) and share one ``GenMsgCycleTime``.

    Raises:
        DbcError: missing or unparsable file, or a message that breaks the rules above.
    """

    def __init__(self, dbc_path: Path | str | None = None) -> None:
        path = Path(dbc_path) if dbc_path is not None else default_dbc_path()
        try:
            database = cantools.database.can.Database()
            database.add_dbc_file(str(path))
        except Exception as err:  # cantools raises many types on a bad file
            raise DbcError(f"{path}: cannot load the CAN database: {err}") from err
        self.path = path
        self._messages: dict[tuple[int, bool], Any] = {}
        self._signals: dict[str, dict[str, _Signal]] = {}
        specs: list[FrameSpec] = []
        cycle_times: set[int] = set()
        for message in database.messages:
            names = [s.name for s in message.signals]
            where = f"{path}: message {message.name}"
            if message.length != 8:
                raise DbcError(f"{where} is {message.length} bytes; rig frames are 8")
            if COUNTER_SIGNAL not in names or CRC_SIGNAL not in names:
                raise DbcError(f"{where} lacks {COUNTER_SIGNAL} or {CRC_SIGNAL}")
            crc = message.get_signal_by_name(CRC_SIGNAL)
            if (crc.start, crc.length, crc.byte_order) != (56, 8, "little_endian"):
                raise DbcError(f"{where}: {CRC_SIGNAL} must be byte 7 (start 56, 8 bits)")
            if not message.cycle_time:
                raise DbcError(f"{where} has no GenMsgCycleTime")
            cycle_times.add(int(message.cycle_time))
            quantities = tuple(n for n in names if n not in (COUNTER_SIGNAL, CRC_SIGNAL))
            self._signals[message.name] = {
                s.name: _Signal(float(s.offset), float(s.scale), (1 << s.length) - 1)
                for s in message.signals
                if s.name in quantities
            }
            key = (message.frame_id, bool(message.is_extended_frame))
            self._messages[key] = message
            specs.append(FrameSpec(message.name, message.frame_id, key[1], quantities))
        if len(cycle_times) != 1:
            raise DbcError(f"{path}: messages must share one GenMsgCycleTime, got {cycle_times}")
        self.frames: tuple[FrameSpec, ...] = tuple(specs)
        """The rig frames, in DBC order."""
        self.sample_period_ns: int = cycle_times.pop() * 1_000_000
        """Time between acquisitions (ns), from ``GenMsgCycleTime``."""

    @property
    def quantities(self) -> tuple[str, ...]:
        """Every measured quantity the DBC carries, e.g. ``("p_i", "p_b", "F_k", ...)``."""
        return tuple(q for spec in self.frames for q in spec.quantities)

    def encode(
        self, counter: int, values: Mapping[str, float], timestamp: float = 0.0
    ) -> list[can.Message]:
        """The frames of one acquisition.

        Args:
            counter: the acquisition's sample counter (taken modulo 2**24).
            values: SI value per quantity; a frame is sent only when all its quantities are
                given (so a rig without ``p_a`` sends no ``BRAKE_AIR``). Values outside a
                sensor's range saturate at its ends, as the sensor would; NaN is refused.
            timestamp: the python-can ``timestamp`` (s) of the frames.

        Raises:
            ValueError: a NaN value.
        """
        frames = []
        for spec in self.frames:
            if not all(q in values for q in spec.quantities):
                continue
            raw: dict[str, int] = {COUNTER_SIGNAL: counter % COUNTER_MODULUS, CRC_SIGNAL: 0}
            for name, signal in self._signals[spec.name].items():
                value = float(values[name])
                if math.isnan(value):
                    raise ValueError(f"{spec.name}: {name} is NaN")
                counts = round((value - signal.low) / signal.scale)
                raw[name] = min(max(counts, 0), signal.top)
            message = self._messages[(spec.frame_id, spec.is_extended)]
            data = bytearray(message.encode(raw, scaling=False, strict=False))
            data[_CRC_BYTE] = frame_crc(spec.frame_id, data)
            frames.append(
                can.Message(
                    timestamp=timestamp,
                    arbitration_id=spec.frame_id,
                    is_extended_id=spec.is_extended,
                    data=data,
                )
            )
        return frames

    def decode(self, frame: can.Message) -> DecodedFrame:
        """Values (SI) and raw counter of one frame.

        Raises:
            UnknownFrameError: id not in the DBC, or a remote frame.
            FrameLengthError: DLC differs from the DBC's.
            ChecksumError: crc8 mismatch.
        """
        key = (frame.arbitration_id, bool(frame.is_extended_id))
        message = self._messages.get(key)
        if message is None or frame.is_remote_frame:
            kind = "remote frame" if frame.is_remote_frame else "frame"
            raise UnknownFrameError(f"unknown {kind} id 0x{frame.arbitration_id:X}")
        data = bytes(frame.data)
        if len(data) != message.length or frame.dlc != message.length:
            msg = f"{message.name}: DLC {frame.dlc} ({len(data)} bytes), expected {message.length}"
            raise FrameLengthError(msg)
        if data[_CRC_BYTE] != (expected := frame_crc(frame.arbitration_id, data)):
            msg = f"{message.name}: crc8 0x{data[_CRC_BYTE]:02X}, expected 0x{expected:02X}"
            raise ChecksumError(msg)
        raw = message.decode(data, decode_choices=False, scaling=False)
        values = {
            name: float(raw[name]) * signal.scale + signal.low
            for name, signal in self._signals[message.name].items()
        }
        return DecodedFrame(message.name, int(raw[COUNTER_SIGNAL]), values)
