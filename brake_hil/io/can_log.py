"""A lab's CAN log replayed as the rig's DAQ: BLF, ASC, TRC, candump (ROS-free).

A vendor tool (Vector, PEAK) or candump logs the rig's frames; :class:`CanLogReplay` reads
the log with python-can's own readers (:class:`can.BLFReader`, :class:`can.ASCReader`,
:class:`can.TRCReader`, :class:`can.CanutilsLogReader`, chosen by the file's suffix: ``.blf``,
``.asc``, ``.trc``, ``.log``) and plays its frames, paced by their logged times at real time or
``rate`` times it, into the live DAQ's own :class:`~brake_hil.io.can_daq.CanDaq` through a
python-can bus (:class:`_LogBus`). So every check of the live DAQ applies unchanged: the DBC
decoding with its CRC and DLC checks, dropouts (counter gaps: ``lost_samples``), a frozen
counter (frames dropped: ``stale_counters``), the acquisition stamps rebuilt from the sample
counter (``t0 + counter * GenMsgCycleTime``), STALE at its deadline; and
:class:`~brake_hil.io.can_acquisition.CanAcquisition` sends each decoded sample once.

Stamps (``stamp_mode``): ``shift`` (default) moves every logged time by one offset so the first
frame is received "now" (the spacing is the log's); ``keep`` keeps the logged times (a BLF or
candump log's are absolute; an ASC or TRC log's may count from the log's start).

The whole log is read (and so checked) when the replay is made: a missing, empty, truncated
or garbled file is a :class:`~brake_hil.errors.RecordingError` naming the file and the problem,
before anything is published. Truncation is seen from a BLF header's file size, a text log's
last line cut off, an ASC log without its closing ``End TriggerBlock``; a candump or TRC log
cut exactly at a line's end cannot be told from a shorter log (its frames' counters still
show what is missing, as dropouts, if the cut is inside the run). Lines python-can's ASC and
candump readers cannot parse raise there; its TRC reader skips them with a warning, which is
taken as an error here. (An ASC log's other event lines are skipped, as the format allows.)
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
import logging
from pathlib import Path
import threading
import time
from typing import Any, Final

import can

from brake_hil.errors import RecordingError
from brake_hil.io.can_acquisition import CanAcquisition
from brake_hil.io.can_daq import CanDaq
from brake_hil.io.replay import Output
from brake_hil.runtime import StampMode

__all__ = ["LOG_READERS", "CanLogReplay", "read_can_log"]

LOG_READERS: Final[Mapping[str, Callable[[str], Any]]] = {
    ".blf": can.BLFReader,
    ".asc": can.ASCReader,
    ".trc": can.TRCReader,
    ".log": can.CanutilsLogReader,
}
"""python-can's reader of each log format, by file suffix."""


class _Unparsed(logging.Handler):
    """Keeps the lines python-can's TRC reader could not parse (it logs and skips them)."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        if "failed to parse" in record.getMessage().lower():
            self.lines.append(record.getMessage())


def _frames(path: Path) -> Iterator[can.Message]:
    reader = LOG_READERS[path.suffix.lower()](str(path))
    unparsed = _Unparsed()
    trc_logger = logging.getLogger("can.io.trc")
    trc_logger.addHandler(unparsed)
    try:
        if isinstance(reader, can.BLFReader):
            size = path.stat().st_size
            if reader.file_size != size:  # written at close; a crash leaves 0 or the old size
                kind = "truncated" if size < reader.file_size else "damaged"
                raise RecordingError(
                    f"{kind} (its header says {reader.file_size} bytes, the file has {size})"
                )
        for frame in reader:
            if unparsed.lines:
                raise RecordingError(f"garbled: {unparsed.lines[0]}")
            yield frame
        if unparsed.lines:
            raise RecordingError(f"garbled: {unparsed.lines[0]}")
    finally:
        trc_logger.removeHandler(unparsed)
        reader.stop()


def _check_text_end(path: Path) -> None:
    """A text log ends with a whole line (and an ASC log with its ``End TriggerBlock``)."""
    with path.open("rb") as stream:
        stream.seek(max(0, path.stat().st_size - 4096))
        tail = stream.read()
    if tail and not tail.endswith(b"\n"):
        raise RecordingError(f"{path}: truncated (its last line is cut off)")
    if path.suffix.lower() == ".asc" and tail and b"end triggerblock" not in tail.lower():
        raise RecordingError(f"{path}: truncated (no 'End TriggerBlock' at its end)")


def read_can_log(path: Path | str) -> list[can.Message]:
    """Every frame of a CAN log, in logged order.

    Raises:
        RecordingError: unknown suffix, missing or unreadable file, a truncated or garbled
            log, no frame in it, or logged times that go backwards.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in LOG_READERS:
        known = ", ".join(LOG_READERS)
        raise RecordingError(f"{path}: not a CAN log this reads (suffix {suffix!r}; {known})")
    if not path.is_file():
        raise RecordingError(f"{path}: no such CAN log")
    if suffix != ".blf":
        _check_text_end(path)
    try:
        frames = list(_frames(path))
    except RecordingError as err:
        raise RecordingError(f"{path}: {err}") from err
    except Exception as err:  # noqa: BLE001 - python-can's readers raise many kinds
        problem = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise RecordingError(f"{path}: unreadable CAN log ({problem})") from err
    if not frames:
        raise RecordingError(f"{path}: no CAN frame in the log (empty, truncated or garbled)")
    previous = frames[0].timestamp
    for index, frame in enumerate(frames):
        if frame.timestamp < previous:
            raise RecordingError(
                f"{path}: logged times go backwards at frame {index} "
                f"({frame.timestamp:.6f} s after {previous:.6f} s)"
            )
        previous = frame.timestamp
    return frames


class _LogBus(can.BusABC):
    """A python-can bus that receives a log's frames when their (scaled) time has come."""

    def __init__(
        self,
        frames: list[can.Message],
        rate: float,
        stamp_mode: StampMode,
        stop: threading.Event,
        ended: threading.Event,
    ) -> None:
        super().__init__(channel="can_log")
        self._frames, self._rate, self._mode = frames, rate, stamp_mode
        self._stop, self._ended = stop, ended
        self._next = 0
        self._first = frames[0].timestamp
        self._start_mono = time.monotonic()
        self._wall_offset = time.time() - self._first  # shift: the first frame is "now"

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        if self._stop.is_set() or self._next >= len(self._frames):
            self._ended.set()
            return None, False
        frame = self._frames[self._next]
        due = self._start_mono + (frame.timestamp - self._first) / self._rate
        wait = due - time.monotonic()
        if wait > 0:
            if timeout is not None and wait > timeout:
                time.sleep(timeout)
                return None, False
            time.sleep(wait)
        self._next += 1
        stamp = frame.timestamp + (self._wall_offset if self._mode is StampMode.SHIFT else 0.0)
        return _with_timestamp(frame, max(stamp, 1e-9)), False  # 0.0 would read as "now"

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        raise can.CanOperationError("a CAN log is read only")

    @property
    def replayed(self) -> int:
        """Frames handed out so far."""
        return self._next


def _with_timestamp(frame: can.Message, timestamp: float) -> can.Message:
    return can.Message(
        timestamp=timestamp,
        arbitration_id=frame.arbitration_id,
        is_extended_id=frame.is_extended_id,
        is_remote_frame=frame.is_remote_frame,
        is_error_frame=frame.is_error_frame,
        is_fd=frame.is_fd,
        dlc=frame.dlc,
        data=frame.data,
        check=False,
    )


class CanLogReplay:
    """A CAN log played through the DBC with the live DAQ's checks, paced by its times.

    Args:
        path: the log (``.blf``, ``.asc``, ``.trc`` or candump ``.log``); read whole here.
        dbc_path: the CAN database; default ``config/brake_rig.dbc``.
        publish_measured: send every quantity the DBC carries, not ``p_i`` alone.
        on_change: called when the DAQ's status changes (see :class:`CanAcquisition`).
        rate: replay speed factor (2.0: twice as fast).
        stamp_mode: ``shift`` or ``keep`` (module docstring).
        stale_after_s: STALE after this long (logged time) without a good frame.

    Raises:
        RecordingError: the log cannot be used (:func:`read_can_log`).
        ValueError: ``rate`` not positive.
    """

    def __init__(
        self,
        path: Path | str,
        dbc_path: Path | str | None = None,
        publish_measured: bool = True,
        on_change: Callable[[], None] = lambda: None,
        rate: float = 1.0,
        stamp_mode: StampMode = StampMode.SHIFT,
        stale_after_s: float = 0.010,
    ) -> None:
        if not rate > 0:
            raise ValueError(f"rate must be positive, got {rate}")
        self.path = Path(path)
        self.frames = read_can_log(self.path)
        self.rate, self.stamp_mode = rate, stamp_mode
        self.duration_s = self.frames[-1].timestamp - self.frames[0].timestamp
        self._stop = threading.Event()  # replaced by run's
        self.ended = threading.Event()
        """Set when the log has been played to its end (or stopped)."""
        self._bus: _LogBus | None = None
        self.daq = CanDaq(
            dbc_path=dbc_path,
            stale_after_s=stale_after_s / rate,
            bus_factory=self._open_bus,
        )
        self.acquisition = acquisition = CanAcquisition(self.daq, publish_measured, on_change)
        logged = {(frame.arbitration_id, frame.is_extended_id) for frame in self.frames}
        carried = {
            q
            for spec in self.daq.codec.frames
            if (spec.frame_id, spec.is_extended) in logged
            for q in spec.quantities
        }
        acquisition.quantities = [q for q in acquisition.quantities if q in carried]
        if "p_i" not in acquisition.quantities:
            raise RecordingError(f"{self.path}: no frame carrying p_i in the CAN log")
        self.quantities = acquisition.quantities
        """The quantities sent: those of the DBC's frames the log holds (``p_i`` always)."""

    def _open_bus(self) -> can.BusABC:
        self._bus = _LogBus(self.frames, self.rate, self.stamp_mode, self._stop, self.ended)
        return self._bus

    @property
    def published(self) -> int:
        """Samples with a ``p_i`` sent so far."""
        return self.acquisition.published

    @property
    def replayed(self) -> int:
        """Logged frames played so far (good or not)."""
        return self._bus.replayed if self._bus is not None else 0

    def run(self, outputs: Mapping[str, Output], stop: threading.Event) -> bool:
        """Play the log once (until ``stop``): each decoded sample to its output; True at its end.

        ``outputs``: per quantity (of :attr:`quantities`), where its samples go.
        """
        self._stop = stop
        self.acquisition.run(outputs, self.ended)
        return self.replayed >= len(self.frames) and not stop.is_set()

    def summary(self) -> dict[str, Any]:
        """The log, how much of it was played, and the DAQ's counters and status."""
        return {
            "can_log": str(self.path),
            "frames": len(self.frames),
            "replayed": self.replayed,
            "log_duration_s": self.duration_s,
            "rate": self.rate,
            "stamp_mode": self.stamp_mode.value,
            **self.acquisition.summary(),
        }
