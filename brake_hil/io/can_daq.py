"""CAN data acquisition of the brake rig: python-can bus, DBC codec, health (ROS-free).

The rig's DAQ sends one set of classic CAN frames per acquisition (``config/brake_rig.dbc``):
``BRAKE_HYDRAULIC`` (``p_i``, ``p_b``), ``BRAKE_MECHANICAL`` (``F_k``, ``x_c``) and, when the
rig has an air-pressure sensor, ``BRAKE_AIR`` (``p_a``). Each carries the 16-bit sensor counts
(the ranges of :mod:`brake_hil.physics.measurement`), a 24-bit ``sample_counter`` shared by the
frames of one acquisition, and a ``crc8`` (CRC-8/SAE-J1850 over the frame id and data bytes
0-6, the AUTOSAR E2E idea of a data id in the checksum) in byte 7.

Use::

    from brake_hil.io.can_daq import CanDaq, DaqStatus

    with CanDaq("slcan", "out/chain_can/rig_can", 1_000_000, stale_after_s=0.010) as daq:
        for sample in daq.poll(timeout=0.005):       # list[DecodedSample]
            sample.frame      # DBC message name, e.g. "BRAKE_HYDRAULIC"
            sample.values     # {"p_i": Pa, "p_b": Pa} / {"F_k": N, "x_c": m} / {"p_a": Pa}
            sample.counter    # unwrapped sample counter (one per sample period)
            sample.stamp_ns   # acquisition time (ns since the epoch, host clock)
        health = daq.health()                         # DaqHealth
        if health.status is not DaqStatus.OK: ...

What happens to each fault (none raises out of :meth:`CanDaq.poll`):

========================  ======================================================  ============
fault                     handling                                                counted in
========================  ======================================================  ============
bad CRC                   frame dropped                                           crc_errors
wrong DLC                 frame dropped                                           dlc_errors
unknown id, remote frame  frame dropped                                           unknown_ids
counter gap               samples missing in between are reported, not invented   lost_samples
counter not advancing     frame dropped (a frozen DAQ: nothing published as       stale_counters
                          fresh); the status goes STALE ``stale_after_s`` after
                          the last frame whose counter advanced
error frame, bus error    counted; status BUS_ERROR for ``error_hold_s``          bus_errors
silent bus                status STALE once no good frame for ``stale_after_s``   age_s
adapter lost / not there  bus closed, reopened with exponential backoff           reconnects
                          (``reconnect_min_s`` doubling to ``reconnect_max_s``)
========================  ======================================================  ============

Status precedence: ADAPTER_LOST > STALE > BUS_ERROR > OK. Before the first good frame the
status is STALE. :attr:`CanDaq.stale_deadline_ns` is the monotonic time at which the status
turns STALE unless another good frame comes (one deadline armed per good frame), so a
watchdog can report a silent or frozen DAQ at that moment rather than at its next poll.

Acquisition time: the DAQ's frames carry no clock, only the counter; the stamp is
``t0 + counter * GenMsgCycleTime``, where ``t0`` tracks the least-delayed frame seen
(``min(receive_time - counter * period)``), allowed to creep up by 100 ppm to follow clock
drift. The stamps of one run are therefore exactly one period apart, and lag the true
acquisition by the smallest transport latency seen.

For an emulated rig, :class:`SlcanPty` is the device side of an slcan adapter on a
pseudo-terminal pair: a :class:`CanDaq` in another process opens its ``device_path`` with
python-can's ``slcan`` interface (which needs ``pyserial``).

Errors::

    BrakeHilError
     +-- CanDaqError                       a CAN set-up problem
          +-- DbcError (ValueError)        the DBC is unusable (named file, message, signal)
          +-- FrameError (ValueError)      one frame is refused by RigFrameCodec.decode
               +-- UnknownFrameError        id not in the DBC, or a remote frame
               +-- FrameLengthError         DLC differs from the DBC's
               +-- ChecksumError            crc8 does not match
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from enum import Enum
import math
from pathlib import Path
import time
from typing import Any, Final, NamedTuple, Self

import can

from brake_hil.errors import (
    CanDaqError,
    ChecksumError,
    DbcError,
    FrameLengthError,
    UnknownFrameError,
)
from brake_hil.io.can_codec import (
    COUNTER_MODULUS,
    COUNTER_SIGNAL,
    CRC_SIGNAL,
    DEFAULT_DBC_PATH,
    DecodedFrame,
    FrameSpec,
    RigFrameCodec,
    crc8_sae_j1850,
    default_dbc_path,
    frame_crc,
)
from brake_hil.io.closing import Closing
from brake_hil.io.slcan_pty import DRAIN_S, DRAIN_SETTLE_S, SlcanPty, slcan_line

__all__ = [
    "COUNTER_MODULUS",
    "COUNTER_SIGNAL",
    "CRC_SIGNAL",
    "DEFAULT_DBC_PATH",
    "DRAIN_SETTLE_S",
    "DRAIN_S",
    "CanDaq",
    "CanDaqError",
    "DaqHealth",
    "DaqStatus",
    "DbcError",
    "DecodedFrame",
    "DecodedSample",
    "FrameSpec",
    "RigFrameCodec",
    "SlcanPty",
    "crc8_sae_j1850",
    "default_dbc_path",
    "frame_crc",
    "slcan_line",
]

_NS_PER_S: Final = 1_000_000_000
_DRIFT_ALLOWANCE: Final = 1e-4  # t0 may creep up by 100 ppm of elapsed time


class DecodedSample(NamedTuple):
    """One good frame, as :meth:`CanDaq.poll` returns it."""

    frame: str  # DBC message name
    values: dict[str, float]  # quantity -> SI value (Pa, N, m)
    counter: int  # unwrapped sample counter
    stamp_ns: int  # acquisition time (ns since the epoch, host clock)
    receive_ns: int  # when the host received the frame (ns since the epoch)


class DaqStatus(Enum):
    """Health of the acquisition, worst first."""

    ADAPTER_LOST = "adapter_lost"  # the bus is not open (never opened, or lost)
    STALE = "stale"  # no good frame for stale_after_s (or none yet)
    BUS_ERROR = "bus_error"  # a bus error within error_hold_s, frames still fresh
    OK = "ok"

    @property
    def diagnostic_level(self) -> int:
        """``diagnostic_msgs/msg/DiagnosticStatus`` level: OK 0, WARN 1, ERROR 2, STALE 3."""
        return {"ok": 0, "bus_error": 1, "adapter_lost": 2, "stale": 3}[self.value]


class DaqHealth(NamedTuple):
    """Snapshot of :class:`CanDaq`'s health and counters (counts since it was made)."""

    status: DaqStatus
    frames_ok: int  # good frames decoded
    crc_errors: int  # frames dropped for a bad crc8
    dlc_errors: int  # frames dropped for a wrong DLC
    unknown_ids: int  # frames dropped: id not in the DBC, or remote frames
    bus_errors: int  # error frames, bus operation errors, unparsable adapter output
    lost_samples: int  # acquisitions missing between received counters, summed over frames
    stale_counters: int  # frames dropped: their sample counter did not advance (frozen DAQ)
    reconnects: int  # successful re-openings of the bus after a loss
    age_s: float  # time since the last good frame (s); inf before the first
    last_error: str  # the most recent problem, "" if none


class _CounterClock:
    """Unwraps the 24-bit counter and reconstructs acquisition stamps (see module doc)."""

    def __init__(self, period_ns: int) -> None:
        self.period_ns = period_ns
        self._restart_after = max(1, _NS_PER_S // period_ns)  # 1 s backwards: a DAQ restart
        self.restarts = 0
        self.reset()

    def reset(self) -> None:
        self._last_raw: int | None = None
        self._unwrapped = 0
        self._t0_ns: float | None = None
        self._t0_counter = 0

    def stamp(self, raw: int, receive_ns: int) -> tuple[int, int]:
        """Unwrapped counter and acquisition stamp (ns) of a frame with counter ``raw``."""
        if self._last_raw is None:
            self._last_raw, self._unwrapped = raw, raw
        delta = (raw - self._last_raw) % COUNTER_MODULUS
        if delta < COUNTER_MODULUS // 2:
            unwrapped = self._unwrapped + delta
            self._last_raw, self._unwrapped = raw, unwrapped
        else:  # behind the newest counter: a late frame, or a DAQ restart
            back = COUNTER_MODULUS - delta
            if back > self._restart_after:
                self.reset()
                self.restarts += 1
                return self.stamp(raw, receive_ns)
            unwrapped = self._unwrapped - back
        offset = receive_ns - unwrapped * self.period_ns
        if self._t0_ns is None:
            self._t0_ns, self._t0_counter = float(offset), unwrapped
        elif unwrapped >= self._t0_counter:
            allowed = (unwrapped - self._t0_counter) * self.period_ns * _DRIFT_ALLOWANCE
            self._t0_ns = min(float(offset), self._t0_ns + allowed)
            self._t0_counter = unwrapped
        return unwrapped, round(self._t0_ns) + unwrapped * self.period_ns


BusFactory = Callable[[], can.BusABC]
"""Makes an open python-can bus (for tests, or buses that need special set-up)."""


class CanDaq(Closing):
    """Acquire the rig's frames from a python-can bus: decode, stamp, watch health.

    Args:
        interface: python-can interface (``"virtual"``, ``"slcan"``, ``"socketcan"``, ...).
        channel: python-can channel (virtual: a name; slcan: the serial device path).
        bitrate: CAN bitrate (bit/s); 1 Mbit/s carries the rig's 3 frames/ms at ~40 % load.
        dbc_path: the CAN database; default :func:`default_dbc_path`.
        stale_after_s: age of the last good frame (s) after which the status is STALE.
        bus_kwargs: extra keyword arguments for ``can.Bus`` (e.g. slcan's
            ``sleep_after_open``).
        bus_factory: makes the bus instead of ``can.Bus(interface, channel, bitrate)``.
        reconnect_min_s: first wait (s) before reopening a lost bus; doubles per failure.
        reconnect_max_s: longest wait (s) between attempts.
        error_hold_s: how long (s) a bus error keeps the status at BUS_ERROR.
        max_consecutive_errors: bus operation errors in a row after which the adapter is
            treated as lost and reopened.

    The bus is opened by ``__enter__`` (or :meth:`open`); a bus that cannot be opened is not
    an error: the status is ADAPTER_LOST and :meth:`poll` retries. Only a configuration that
    can never work raises :class:`CanDaqError`: an unknown interface or a bad DBC at once, a
    missing driver module when the bus is first opened.
    """

    def __init__(
        self,
        interface: str = "virtual",
        channel: str = "brake_hil",
        bitrate: int = 1_000_000,
        dbc_path: Path | str | None = None,
        stale_after_s: float = 0.010,
        *,
        bus_kwargs: Mapping[str, Any] | None = None,
        bus_factory: BusFactory | None = None,
        reconnect_min_s: float = 0.05,
        reconnect_max_s: float = 2.0,
        error_hold_s: float = 0.5,
        max_consecutive_errors: int = 10,
    ) -> None:
        if stale_after_s <= 0 or reconnect_min_s <= 0 or reconnect_max_s < reconnect_min_s:
            msg = (
                f"stale_after_s ({stale_after_s} s) and reconnect_min_s ({reconnect_min_s} s) "
                f"must be > 0 and reconnect_max_s ({reconnect_max_s} s) >= reconnect_min_s"
            )
            raise ValueError(msg)
        if bus_factory is None and interface not in can.interfaces.VALID_INTERFACES:
            raise CanDaqError(
                f"CAN interface {interface!r} is unknown (python-can has "
                f"{', '.join(sorted(can.interfaces.VALID_INTERFACES))})"
            )
        self.codec = RigFrameCodec(dbc_path)
        self.interface, self.channel, self.bitrate = interface, channel, bitrate
        self.stale_after_s = stale_after_s
        self._bus_kwargs = dict(bus_kwargs or {})
        self._factory = bus_factory or self._make_bus
        self._backoff = (reconnect_min_s, reconnect_max_s)
        self._error_hold_ns = round(error_hold_s * _NS_PER_S)
        self._max_consecutive = max_consecutive_errors
        self._clock = _CounterClock(self.codec.sample_period_ns)
        self._bus: can.BusABC | None = None
        self._ever_opened = False
        self._retry_at_ns = 0
        self._retry_wait_s = reconnect_min_s
        self._consecutive_errors = 0
        self._last_good_ns: int | None = None  # monotonic
        self._stale_after_ns = round(stale_after_s * _NS_PER_S)
        self.stale_deadline_ns: int | None = None
        """Monotonic ns at which the status turns STALE unless a good frame comes first;
        None before the first good frame."""
        self._last_bus_error_ns: int | None = None  # monotonic
        self._last_counter: dict[str, int] = {}
        self._counts = dict.fromkeys(
            (
                "frames_ok",
                "crc_errors",
                "dlc_errors",
                "unknown_ids",
                "bus_errors",
                "lost_samples",
                "stale_counters",
                "reconnects",
            ),
            0,
        )
        self._last_error = ""

    # -- bus handling -------------------------------------------------------------------

    def _make_bus(self) -> can.BusABC:
        kwargs = {"bitrate": self.bitrate, **self._bus_kwargs}
        return can.Bus(interface=self.interface, channel=self.channel, **kwargs)

    def open(self) -> bool:
        """Try to open the bus now; True if it is open. Never raises for a missing adapter.

        Raises:
            CanDaqError: the interface is unknown or its driver module is missing.
        """
        if self._bus is not None:
            return True
        try:
            bus = self._factory()
        except can.CanInterfaceNotImplementedError as err:
            msg = f"CAN interface {self.interface!r} ({self.channel}) is unavailable: {err}"
            raise CanDaqError(msg) from err
        except (can.CanError, OSError, ValueError) as err:
            self._lost(f"cannot open {self.interface} {self.channel}: {err}")
            return False
        flush = getattr(bus, "flush", None)  # slcan: drop what the adapter buffered meanwhile
        if callable(flush):
            try:
                flush()
            except (can.CanError, OSError):
                pass
        self._bus = bus
        if self._ever_opened:
            self._counts["reconnects"] += 1
        self._ever_opened = True
        self._retry_wait_s = self._backoff[0]
        self._consecutive_errors = 0
        return True

    def _lost(self, reason: str) -> None:
        """Close the bus (if open) and schedule the next attempt with exponential backoff."""
        self._last_error = reason
        if self._bus is not None:
            try:
                self._bus.shutdown()
            except Exception:  # noqa: BLE001 - a dead adapter may fail to close in any way
                pass
            self._bus = None
        self._retry_at_ns = time.monotonic_ns() + round(self._retry_wait_s * _NS_PER_S)
        self._retry_wait_s = min(2.0 * self._retry_wait_s, self._backoff[1])

    def close(self) -> None:
        """Shut the bus down (idempotent)."""
        if self._bus is not None:
            bus, self._bus = self._bus, None
            bus.shutdown()

    def __enter__(self) -> Self:
        self.open()
        return super().__enter__()

    # -- acquisition --------------------------------------------------------------------

    def poll(self, timeout: float = 0.0, max_frames: int = 1000) -> list[DecodedSample]:
        """Good frames received within ``timeout`` (s), in arrival order.

        Waits up to ``timeout`` for the first frame, then takes whatever is already queued
        without waiting (at most ``max_frames``). Bad frames, bus errors and a lost adapter
        are counted and reported by :meth:`health`, never raised; a lost adapter is reopened
        here once its backoff has passed.
        """
        samples: list[DecodedSample] = []
        if self._bus is None:
            now = time.monotonic_ns()
            if now < self._retry_at_ns or not self.open():
                wait_ns = max(0, self._retry_at_ns - time.monotonic_ns())
                time.sleep(min(timeout, wait_ns / _NS_PER_S))
                return samples
        bus = self._bus
        assert bus is not None
        wait: float | None = timeout
        while len(samples) < max_frames:
            try:
                frame = bus.recv(wait)
            except (can.CanInitializationError, OSError) as err:
                self._lost(f"adapter lost: {err}")
                break
            except can.CanOperationError as err:
                self._bus_error(f"bus error: {err}")
                if self._consecutive_errors >= self._max_consecutive:
                    self._lost(f"adapter lost after {self._consecutive_errors} errors: {err}")
                    break
                continue
            except (ValueError, IndexError, UnicodeDecodeError) as err:  # unparsable adapter text
                self._bus_error(f"unparsable frame from the adapter: {err}")
                continue
            if frame is None:
                break
            wait = 0.0
            self._consecutive_errors = 0
            if frame.is_error_frame:
                self._bus_error(f"error frame 0x{frame.arbitration_id:X}")
                continue
            if (sample := self._accept(frame)) is not None:
                samples.append(sample)
        return samples

    def _bus_error(self, reason: str) -> None:
        self._counts["bus_errors"] += 1
        self._consecutive_errors += 1
        self._last_bus_error_ns = time.monotonic_ns()
        self._last_error = reason

    def _accept(self, frame: can.Message) -> DecodedSample | None:
        try:
            decoded = self.codec.decode(frame)
        except UnknownFrameError as err:
            self._counts["unknown_ids"] += 1
            self._last_error = str(err)
            return None
        except FrameLengthError as err:
            self._counts["dlc_errors"] += 1
            self._last_error = str(err)
            return None
        except ChecksumError as err:
            self._counts["crc_errors"] += 1
            self._last_error = str(err)
            return None
        receive_ns = round(frame.timestamp * _NS_PER_S) if frame.timestamp else time.time_ns()
        restarts = self._clock.restarts
        counter, stamp_ns = self._clock.stamp(decoded.counter, receive_ns)
        if self._clock.restarts != restarts:  # the DAQ restarted: its counters start again
            self._last_counter.clear()
        previous = self._last_counter.get(decoded.name)
        if previous is not None and counter <= previous:
            # A frozen DAQ repeats its last frame: nothing new was acquired, so nothing is
            # fresh (and the deadline is not re-armed).
            self._counts["stale_counters"] += 1
            self._last_error = (
                f"sample counter of {decoded.name} did not advance ({decoded.counter}; "
                f"{self._counts['stale_counters']} frames dropped)"
            )
            return None
        if previous is not None and counter > previous + 1:
            self._counts["lost_samples"] += counter - previous - 1
        self._last_counter[decoded.name] = counter
        self._counts["frames_ok"] += 1
        self._last_good_ns = now = time.monotonic_ns()
        self.stale_deadline_ns = now + self._stale_after_ns
        return DecodedSample(decoded.name, decoded.values, counter, stamp_ns, receive_ns)

    def health(self) -> DaqHealth:
        """Status and counters now (the status is computed at the call)."""
        now = time.monotonic_ns()
        age_s = math.inf if self._last_good_ns is None else (now - self._last_good_ns) / 1e9
        if self._bus is None:
            status = DaqStatus.ADAPTER_LOST
        elif self.stale_deadline_ns is None or now >= self.stale_deadline_ns:
            status = DaqStatus.STALE
        elif (
            self._last_bus_error_ns is not None
            and now - self._last_bus_error_ns < self._error_hold_ns
        ):
            status = DaqStatus.BUS_ERROR
        else:
            status = DaqStatus.OK
        return DaqHealth(status=status, age_s=age_s, last_error=self._last_error, **self._counts)
