"""Run ``brake-hil`` in-process on one input and classify what happened.

Outcomes: ``answer`` (exit 0), ``refused`` (exit 2 and exactly one stderr line
``brake-hil CMD: error: ...``), and the failures ``bad_refusal`` (exit 2 with more or less
than one line), ``traceback`` (an exception escaped ``main``), ``hang`` (over
:data:`DEADLINE_S`), ``wrong`` (exit 0 but the answer fails the caller's check).

A hang is measured in CPU seconds of this process (a busy 2-core runner stretches wall time
several-fold, CPU time hardly at all); a run blocked without using the CPU (a FIFO opened) is
stopped by an alarm at :data:`WALL_FACTOR` times the deadline in wall time.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
import contextlib
from dataclasses import dataclass
import io
import signal
import time
import traceback
from types import FrameType

from brake_hil.cli import main

DEADLINE_S = 10.0
"""Longest a command may take on one hostile input (s)."""
WALL_FACTOR = 6.0
"""A run is stopped after this many deadlines of wall time."""
FAILURES = ("bad_refusal", "traceback", "hang", "wrong")


class _Hang(BaseException):
    """Raised by the alarm when a command runs past its deadline."""


@dataclass(frozen=True)
class Run:
    """What one command did."""

    argv: tuple[str, ...]
    outcome: str  # answer, refused, bad_refusal, traceback, hang, wrong
    status: int | None
    stdout: str
    stderr: str
    seconds: float  # wall time
    cpu_seconds: float  # this process's CPU time

    def describe(self) -> str:
        """The run in a few lines, for an assertion message."""
        return (
            f"brake-hil {' '.join(self.argv)} -> {self.outcome} (exit {self.status}, "
            f"{self.seconds:.1f} s, {self.cpu_seconds:.1f} s CPU)\n"
            f"stderr: {self.stderr[-3000:]}\nstdout: {self.stdout[-500:]}"
        )


@contextlib.contextmanager
def _alarm(seconds: float) -> Iterator[None]:
    def ring(signum: int, frame: FrameType | None) -> None:
        raise _Hang

    previous = signal.signal(signal.SIGALRM, ring)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def run_cli(
    argv: Sequence[str],
    check_answer: Callable[[str], str | None] | None = None,
    deadline_s: float = DEADLINE_S,
) -> Run:
    """Run ``brake-hil argv`` in this process; ``check_answer(stdout)`` returns a problem.

    A run over the deadline in CPU time, or stopped by the alarm, is a ``hang``.
    """
    out, err = io.StringIO(), io.StringIO()
    status: int | None = None
    outcome = ""
    started, cpu_started = time.perf_counter(), time.process_time()
    try:
        with (
            _alarm(WALL_FACTOR * deadline_s),
            contextlib.redirect_stdout(out),
            contextlib.redirect_stderr(err),
        ):
            status = main(list(argv))
    except _Hang:
        outcome = "hang"
    except SystemExit as stop:  # argparse
        status = stop.code if isinstance(stop.code, int) else 2
    except Exception:  # noqa: BLE001 (what the fuzz looks for)
        err.write(traceback.format_exc())
        outcome = "traceback"
    seconds = time.perf_counter() - started
    cpu_seconds = time.process_time() - cpu_started
    stderr_lines = [line for line in err.getvalue().splitlines() if line.strip()]
    if not outcome:
        if cpu_seconds > deadline_s:
            outcome = "hang"
        elif status == 0:
            problem = check_answer(out.getvalue()) if check_answer is not None else None
            outcome = "answer" if problem is None else "wrong"
            if problem is not None:
                err.write(f"\n[check] {problem}")
        elif status == 2 and len(stderr_lines) == 1 and ": error: " in stderr_lines[0]:
            outcome = "refused"
        else:
            outcome = "bad_refusal"
    return Run(tuple(argv), outcome, status, out.getvalue(), err.getvalue(), seconds, cpu_seconds)
