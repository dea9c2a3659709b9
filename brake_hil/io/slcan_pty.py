"""The device side of an slcan adapter on a pseudo-terminal pair, for an emulated rig.

A :class:`~brake_hil.io.can_daq.CanDaq` in another process opens the pty's ``device_path``
with python-can's ``slcan`` interface (which needs ``pyserial``). POSIX only (ROS-free).
"""

from __future__ import annotations

from collections.abc import Iterable
import errno
import os
from pathlib import Path
import struct
import time

import can

from brake_hil.io.closing import Closing

__all__ = ["DRAIN_S", "DRAIN_SETTLE_S", "SlcanPty", "slcan_line"]


def slcan_line(frame: can.Message) -> bytes:
    r"""The slcan (Lawicel) text of a classic data frame, ``tIIILDD..\r`` (``T`` if extended)."""
    data = bytes(frame.data).hex().upper()
    if frame.is_extended_id:
        return f"T{frame.arbitration_id:08X}{len(frame.data)}{data}\r".encode()
    return f"t{frame.arbitration_id:03X}{len(frame.data)}{data}\r".encode()


DRAIN_S = 5.0
"""How long an emulated adapter that closes waits for its reader to read what it sent (s)."""

DRAIN_SETTLE_S = 0.05
"""How long the reader's queue must stay empty before a closing adapter counts it read (s)."""


class SlcanPty(Closing):
    r"""The device side of an slcan adapter on a pseudo-terminal pair (for an emulated rig).

    A reader in any process opens :attr:`device_path` (or ``link_path``, a symlink made to
    it) with python-can's ``slcan`` interface. Commands the reader sends (``O``, ``C``,
    ``S8``, ...) are acknowledged with ``\r``; frames are written without blocking, and
    dropped (counted in :attr:`dropped`) while nobody reads, as on a bus without receivers.

    Args:
        link_path: optional symlink to create to the device (replaced if it is a symlink).
    """

    def __init__(self, link_path: Path | str | None = None) -> None:
        import tty  # POSIX only, like pseudo-terminals

        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo, no line editing before the reader sets its mode
        os.set_blocking(self._master, False)
        self.device_path = os.ttyname(self._slave)
        self.link_path = Path(link_path) if link_path is not None else None
        if self.link_path is not None:
            if self.link_path.is_symlink():
                self.link_path.unlink()
            self.link_path.symlink_to(self.device_path)
        self.dropped = 0
        self.sent = 0
        self.reader_open = False  # a reader has sent slcan's open command (``O``)

    def poll_reader(self) -> bool:
        """Answer the reader's commands; True once it has opened the channel."""
        self._answer_commands()
        return self.reader_open

    def _answer_commands(self) -> None:
        try:
            incoming = os.read(self._master, 4096)
        except BlockingIOError:
            return
        except OSError as err:  # EIO: no reader has the device open
            if err.errno != errno.EIO:
                raise
            return
        acks = incoming.count(b"\r")
        if b"O\r" in incoming:
            self.reader_open = True
        if acks:
            try:
                os.write(self._master, b"\r" * acks)
            except (BlockingIOError, OSError):
                pass

    def send(self, frames: Iterable[can.Message], wait_s: float = 0.0) -> int:
        """Write frames as slcan text; returns how many were written (the rest are dropped).

        ``wait_s`` > 0: while the pty's buffer is full (the reader lags), retry a frame for up
        to that long before dropping it, as a DAQ's own buffer would hold it (for tests whose
        reader may be starved for a while on a busy machine).
        """
        self._answer_commands()
        written = 0
        for frame in frames:
            line = slcan_line(frame)
            give_up = time.monotonic() + wait_s
            count = 0
            while True:
                try:
                    count += os.write(self._master, line[count:])
                except (BlockingIOError, OSError):
                    pass
                if count == len(line) or (count == 0 and time.monotonic() >= give_up):
                    break
                if count and time.monotonic() >= give_up + 0.01:
                    break  # a partial line: finished below
                time.sleep(0.0005)
                self._answer_commands()
            if count == len(line):
                written += 1
            else:  # a partial line would corrupt the next one: end it
                self.dropped += 1
                if count:
                    self._finish_partial(line[count:])
        self.sent += written
        return written

    def _finish_partial(self, rest: bytes) -> None:
        deadline = time.monotonic() + 0.01
        while rest and time.monotonic() < deadline:
            try:
                rest = rest[os.write(self._master, rest) :]
            except BlockingIOError:
                time.sleep(0.0002)
            except OSError:
                return

    def unread(self) -> int:
        """Bytes written that the reader has not read yet (the device's input queue)."""
        import fcntl
        import termios

        try:
            queued = fcntl.ioctl(self._slave, termios.FIONREAD, b"\0\0\0\0")
        except OSError:
            return 0
        return int(struct.unpack("i", queued)[0])

    def close(self, drain_s: float = DRAIN_S) -> None:
        """Close both ends (a reader sees the adapter vanish) and remove the symlink.

        First, for up to ``drain_s``, wait while a reader has frames still to read: closing
        the pseudo-terminal discards them (a reader lagging 18 ms behind on a busy machine
        lost the last 18 samples of a run). The queue must stay empty for ``DRAIN_SETTLE_S``:
        the kernel moves written bytes to the reader's queue on a worker thread, so on a
        busy machine a frame just written may not show in it yet.
        """
        deadline = time.monotonic() + drain_s
        drained_since: float | None = None  # when the reader's queue was last seen empty
        while self.reader_open and time.monotonic() < deadline:
            now = time.monotonic()
            if self.unread() > 0:
                drained_since = None
            elif drained_since is None:
                drained_since = now
            elif now - drained_since >= DRAIN_SETTLE_S:
                break
            self._answer_commands()
            time.sleep(0.005)
        if self.link_path is not None and self.link_path.is_symlink():
            self.link_path.unlink()
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
