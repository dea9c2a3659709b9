"""Progress of long commands on stderr: a tqdm bar in a terminal, a line every few seconds not.

In a terminal the bar redraws in place (every second at least, so the elapsed time moves
while one step takes long). When stderr is not a terminal (CI, ``| tee``, a log file) every
redraw is its own line, at most one per :data:`LINE_INTERVAL_S` seconds and at least one
every :data:`LINE_INTERVAL_S` seconds while the work runs, so a log shows that it is alive.
Nothing is drawn before :data:`QUIET_START_S` (terminal) or :data:`LINE_INTERVAL_S` (not)
seconds: a command refused at its door prints its one error line and nothing else; work that
ends sooner than that prints its final state once.

Work over many recordings (``cases``, ``benchmark``, ``regress``, ``diagnose`` of many) shows
one :func:`fleet_bar`: recordings done, failed and left, and the rate per minute.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
import sys
import threading
from typing import IO

from tqdm import tqdm

__all__ = ["LINE_INTERVAL_S", "QUIET_START_S", "FleetBar", "fleet_bar", "progress_bar"]

LINE_INTERVAL_S = 5.0
"""Seconds between progress lines when stderr is not a terminal."""
QUIET_START_S = 0.5
"""Seconds a terminal's bar waits before its first draw."""


class _Lines:
    """A file for tqdm that writes each redraw as one line (no carriage returns)."""

    def __init__(self, stream: IO[str]) -> None:
        self._stream = stream

    def write(self, text: str) -> None:
        line = text.replace("\r", "").rstrip()
        if line:
            self._stream.write(line + "\n")

    def flush(self) -> None:
        self._stream.flush()


@contextmanager
def progress_bar(
    total: float, desc: str, unit: str, stream: IO[str] | None = None, **options: object
) -> Iterator[tqdm]:  # type: ignore[type-arg]
    """A tqdm bar on ``stream`` (stderr) that also redraws on a timer (see the module).

    Args:
        total: the work's size, in ``unit``.
        desc: the bar's label.
        unit: what one step is (``"step"``, ``"case"``, ``"s"``).
        stream: where it goes (default ``sys.stderr``).
        **options: more tqdm options (``bar_format``, ...).
    """
    target = sys.stderr if stream is None else stream
    terminal = target.isatty()
    interval = 1.0 if terminal else LINE_INTERVAL_S
    bar = tqdm(
        total=total,
        desc=desc,
        unit=unit,
        file=target if terminal else _Lines(target),
        mininterval=0.1 if terminal else LINE_INTERVAL_S,
        ascii=None if terminal else True,
        dynamic_ncols=terminal,
        ncols=None if terminal else 100,
        delay=QUIET_START_S if terminal else LINE_INTERVAL_S,
        **options,  # type: ignore[arg-type]
    )
    stop = threading.Event()

    def tick() -> None:
        while not stop.wait(interval):
            bar.refresh()

    timer = threading.Thread(target=tick, name="progress", daemon=True)
    timer.start()
    finished = False
    try:
        yield bar
        finished = True
    finally:
        stop.set()
        timer.join()
        if finished and bar.last_print_t < bar.start_t + bar.delay:
            bar.refresh()  # quick work: its final state, once
            if terminal:
                target.write("\n")
        bar.close()


class FleetBar:
    """Recordings done, failed and left, and recordings per minute, on one tqdm bar."""

    def __init__(self, bar: tqdm, unit: str) -> None:  # type: ignore[type-arg]
        self.bar = bar
        self.unit = unit
        self.done = 0
        self.failed = 0
        self.count(0, 0)

    @property
    def left(self) -> int:
        """Recordings neither done nor failed yet."""
        return max(0, int(self.bar.total) - self.done - self.failed)

    def count(self, done: int, failed: int) -> None:
        """Show ``done`` recordings done and ``failed`` failed so far."""
        self.done, self.failed = done, failed
        minutes = float(self.bar.format_dict["elapsed"]) / 60.0
        rate = (done + failed) / minutes if minutes > 0.0 else 0.0
        self.bar.set_postfix_str(
            f"{done} done, {failed} failed, {self.left} left, {rate:.1f} {self.unit}s/min",
            refresh=False,
        )
        self.bar.update(done + failed - self.bar.n)

    def finished(self, ok: bool) -> None:
        """One more recording done (``ok``) or failed."""
        self.count(self.done + ok, self.failed + (not ok))

    def write(self, line: str) -> None:
        """``line`` on stdout, above the bar."""
        self.bar.write(line, file=sys.stdout)
        sys.stdout.flush()


@contextmanager
def fleet_bar(
    total: int, desc: str, unit: str = "recording", stream: IO[str] | None = None
) -> Iterator[FleetBar]:
    """A :func:`progress_bar` of ``total`` recordings, counted by :class:`FleetBar`.

    Args:
        total: recordings in all.
        desc: the bar's label (the command: ``"cases"``, ``"benchmark"``, ...).
        unit: what one item is (``"recording"``, ``"case"``).
        stream: where it goes (default ``sys.stderr``).
    """
    bar_format = (
        "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} [{elapsed}<{remaining}{postfix}]"
    )
    with progress_bar(total, desc, unit, stream, bar_format=bar_format) as bar:
        yield FleetBar(bar, unit)
