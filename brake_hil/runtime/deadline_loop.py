"""The 1 kHz loop on absolute deadlines.

Sleeping, SCHED_FIFO, :class:`DeadlineLoop` and :class:`PhaseLock`.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
import ctypes
import ctypes.util
import math
import os
import threading
import time
from typing import NamedTuple

import numpy as np

from brake_hil.runtime.timing import (
    DEFAULT_PERIOD_NS,
    LATE_TICK_NS,
    NS_PER_S,
    Clock,
    LoopStatistics,
    Sleep,
)
from brake_hil.types import IntArray

# --------------------------------------------------------------------------- sleeping


def sleep_until(
    deadline_ns: int,
    spin_ns: int,
    clock: Clock = time.monotonic_ns,
    sleep: Sleep = time.sleep,
    idle: Callable[[], object] | None = None,
) -> int:
    """Wait until ``deadline_ns`` (monotonic) and return the wake-up time (ns).

    Sleeps until ``spin_ns`` before the deadline (the kernel's wake-up is late by tens of
    microseconds, more under load), then spins with ``sleep(0)``, which releases the GIL on
    every turn so the thread that receives samples is never blocked by the spin. ``idle``,
    when given, is called on every turn of the spin (e.g. to take input as it arrives).
    """
    remaining = deadline_ns - spin_ns - clock()
    if remaining > 0:
        sleep(remaining / NS_PER_S)
    now = clock()
    while now < deadline_ns:
        if idle is not None:
            idle()
        sleep(0)
        now = clock()
    return now


_PR_SET_TIMERSLACK = 29


def set_timer_slack(slack_ns: int = 1) -> bool:
    """Set the calling thread's timer slack (Linux ``prctl``); True on success.

    The default slack of 50 us lets the kernel defer a sleeper's wake-up to batch timers;
    1 ns asks for the wake-up on time. Elsewhere (or without libc) nothing happens.
    """
    name = ctypes.util.find_library("c")
    if name is None:
        return False
    try:
        libc = ctypes.CDLL(name, use_errno=True)
        return int(libc.prctl(_PR_SET_TIMERSLACK, ctypes.c_ulong(slack_ns), 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False


def set_realtime_priority(priority: int, thread_id: int = 0) -> bool:
    """Run a thread (default: the calling one) under ``SCHED_FIFO`` at ``priority`` (1-99).

    True on success. Needs CAP_SYS_NICE (root, or an rtprio limit); without it nothing
    changes. 0 does nothing. Threads started afterwards by that thread inherit the policy.
    """
    if priority <= 0 or not hasattr(os, "sched_setscheduler"):
        return False
    try:
        os.sched_setscheduler(thread_id, os.SCHED_FIFO, os.sched_param(min(priority, 99)))
    except (OSError, ValueError):
        return False
    return True


def set_process_realtime_priority(priority: int) -> int:
    """``SCHED_FIFO`` at ``priority`` for every thread of this process that exists now.

    The middleware's receive threads included (Linux ``/proc/self/task``), and so for the
    threads they start later. Returns how many threads were changed.

    A real-time loop thread should then run one step higher, so that nothing else in the
    process preempts it, while the threads that feed it are not preempted by ordinary load
    (a thread holding the GIL descheduled by another process stalls the loop).
    """
    if priority <= 0:
        return 0
    try:
        threads = [int(name) for name in os.listdir("/proc/self/task")]
    except OSError:
        threads = [0]
    return sum(set_realtime_priority(priority, thread) for thread in threads)


# --------------------------------------------------------------------------- the loop


HELD_POLL_S = 0.01
"""How often a held :class:`DeadlineLoop`'s thread calls its ``while_held`` (s)."""


class Tick(NamedTuple):
    """One pass of a :class:`DeadlineLoop`."""

    slot: int  # grid slot of the deadline (counts skipped slots too)
    deadline_ns: int  # monotonic
    wake_ns: int  # monotonic, when the tick began
    skipped: int  # later slots that had passed too at the wake-up; not run, skipped


class DeadlineLoop:
    """Call ``tick`` at absolute deadlines ``t0 + k period`` on a dedicated thread.

    Args:
        tick: the work of one tick; it gets the :class:`Tick`.
        period_ns: grid period (ns).
        spin_ns: how long before a deadline sleeping stops and spinning starts (ns); only
            under ``SCHED_FIFO``: a thread at normal priority sleeps to each deadline.
        statistics: where ``period_error``, ``tick_work``, ticks, late ticks, overruns and
            skipped slots are counted.
        realtime_priority: ``SCHED_FIFO`` priority of the thread (0: normal scheduling).
        idle: called on every turn of the spin before a deadline (work that may run early).
        while_held: called by the loop's thread every :data:`HELD_POLL_S` while it is held
            (work that must not wait for the first driven tick, e.g. subscribing).
        clock, sleep: injectable for tests.

    An exception raised by ``tick`` stops the loop; it is kept in :attr:`error` and passed
    to ``on_error``.

    *Held* (``start(held=True)``): the thread starts but waits, and another thread runs the
    ticks with :meth:`drive` at its own deadlines (a replaying source stepping the model on its
    own thread, :mod:`brake_hil.nodes.container`), with the same accounting; :meth:`release`
    hands the ticks back to the loop's own grid from then on.
    """

    def __init__(
        self,
        tick: Callable[[Tick], None],
        period_ns: int = DEFAULT_PERIOD_NS,
        spin_ns: int = 150_000,
        statistics: LoopStatistics | None = None,
        *,
        realtime_priority: int = 0,
        on_error: Callable[[BaseException], None] | None = None,
        idle: Callable[[], object] | None = None,
        while_held: Callable[[], object] | None = None,
        clock: Clock = time.monotonic_ns,
        sleep: Sleep = time.sleep,
        name: str = "deadline-loop",
    ) -> None:
        if period_ns <= 0 or spin_ns < 0:
            raise ValueError(f"period_ns must be > 0 and spin_ns >= 0, got {period_ns}, {spin_ns}")
        self._tick = tick
        self.period_ns = period_ns
        self.spin_ns = min(spin_ns, period_ns)
        self.statistics = statistics if statistics is not None else LoopStatistics()
        self._priority = realtime_priority
        self._on_error = on_error
        self._idle = idle
        self._while_held = while_held
        self._clock = clock
        self._sleep = sleep
        self._stop = threading.Event()
        self._released = threading.Event()  # set: the loop's own thread runs the ticks
        self._released.set()
        self._driven_slot = 0
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._phase_request: int | None = None
        self._first_deadline_ns: int | None = None
        self._phase: int | None = None
        self.error: BaseException | None = None
        self.realtime = False  # SCHED_FIFO obtained
        self.timer_slack = False  # 1 ns timer slack obtained

    def start(self, first_deadline_ns: int | None = None, *, held: bool = False) -> None:
        """Start the thread; the first deadline defaults to one period from now.

        ``held``: the thread waits until :meth:`release` (ticks come from :meth:`drive`
        meanwhile); its first deadline is then one period after the release.
        """
        self._first_deadline_ns = first_deadline_ns
        if held:
            self._released.clear()
        self._thread.start()

    def stop(self, timeout_s: float = 2.0) -> None:
        """Ask the loop to stop after its current tick and wait for it (idempotent)."""
        self._stop.set()
        self._released.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout_s)

    @property
    def running(self) -> bool:
        """True while the thread runs (held or not)."""
        return self._thread.is_alive()

    @property
    def held(self) -> bool:
        """True while the ticks come from :meth:`drive`, not the loop's own grid."""
        return not self._released.is_set()

    @property
    def driven_ticks(self) -> int:
        """Ticks run by :meth:`drive` (on the driver's thread) so far."""
        return self._driven_slot

    def release(self) -> None:
        """End the hold: the loop's thread runs the ticks from one period from now."""
        self._released.set()

    def drive(self, deadline_ns: int, wake_ns: int) -> bool:
        """Run one tick now, on the calling thread, while the loop is held.

        ``deadline_ns``: when the caller's own tick was due; ``wake_ns``: when it began
        (monotonic). Counted as the loop's own ticks are (period error, tick work, late ticks,
        overruns). An exception from ``tick`` stops the loop as in its own thread. Returns False
        (and does nothing) once the loop is released, stopped or failed.
        """
        if self._released.is_set() or self._stop.is_set():
            return False
        if self._phase is None:
            self._phase = deadline_ns % self.period_ns
        try:
            self._run_tick(self._driven_slot, deadline_ns, wake_ns, 0)
        except BaseException as err:  # noqa: BLE001 - handed to the owner, the loop ends
            self._fail(err)
            self._stop.set()
            self._released.set()
            return False
        self._driven_slot += 1
        return True

    def request_phase(self, phase_ns: int) -> None:
        """Move the grid so deadlines fall at ``phase_ns`` modulo the period (ns, monotonic).

        Applied after the current tick; the grid stays absolute from then on.
        """
        self._phase_request = phase_ns % self.period_ns

    @property
    def phase_ns(self) -> int | None:
        """Phase of the current grid (ns modulo the period), None before the start."""
        return self._phase

    def run_ticks(self, count: int, first_deadline_ns: int) -> None:
        """Run ``count`` ticks on the calling thread (tests, benchmarks)."""
        self._first_deadline_ns = first_deadline_ns
        self._loop(count)

    def _run(self) -> None:
        self.timer_slack = set_timer_slack(1)
        self.realtime = set_realtime_priority(self._priority)
        if not self.realtime:
            # At normal priority a spin buys no timing (the kernel preempts the spinner for
            # whatever else is runnable) and costs the CPU the threads feeding the loop need:
            # on a busy 2-core machine the spinning model lagged its input by seconds.
            self.spin_ns = 0
        try:
            while not self._released.wait(HELD_POLL_S):
                if self._while_held is not None:
                    self._while_held()
            if self._stop.is_set():
                return
            if self._driven_slot:  # after a hold: the grid starts one period from the release
                self._first_deadline_ns = self._clock() + self.period_ns
            self._loop(None)
        except BaseException as err:  # noqa: BLE001 - handed to the owner, the thread ends
            self._fail(err)

    def _fail(self, err: BaseException) -> None:
        self.error = err
        if self._on_error is not None:
            self._on_error(err)

    def _run_tick(self, slot: int, deadline: int, wake: int, skipped: int) -> int:
        """Count one tick, run it; the time it ended (ns)."""
        stats = self.statistics
        counters = stats.counters
        counters.ticks += 1
        counters.ticks_skipped += skipped
        lateness = wake - deadline
        if lateness >= LATE_TICK_NS:
            counters.late_ticks += 1
        stats.add("period_error", lateness)
        self._tick(Tick(slot, deadline, wake, skipped))
        end = self._clock()
        stats.add("tick_work", end - wake)
        if end > deadline + (skipped + 1) * self.period_ns:
            counters.overruns += 1
        return end

    def _loop(self, count: int | None) -> None:
        period = self.period_ns
        counters = self.statistics.counters
        deadline = self._first_deadline_ns
        if deadline is None:
            deadline = self._clock() + period
        self._phase = deadline % period
        slot = self._driven_slot  # after a hold, the slots go on from the driven ones
        ticks = 0
        while not self._stop.is_set() and (count is None or ticks < count):
            wake = sleep_until(deadline, self.spin_ns, self._clock, self._sleep, self._idle)
            lateness = wake - deadline
            skipped = lateness // period if lateness >= period else 0
            end = self._run_tick(slot, deadline, wake, skipped)
            ticks += 1
            slot += skipped + 1
            deadline += (skipped + 1) * period
            requested = self._phase_request
            if requested is not None:
                self._phase_request = None
                shifted = end - (end % period) + requested  # first slot of the new grid
                if shifted <= end:
                    shifted += period
                deadline = shifted
                self._phase = requested
                counters.phase_shifts += 1


class PhaseLock:
    """Choose the tick phase that steps samples soonest after they arrive.

    Arrival times (monotonic ns) are folded modulo the period into ``bins`` bins; the phase
    chosen is the end of the shortest circular arc of bins that holds ``quantile`` of the
    recent arrivals, plus ``margin_ns``. A tick at that phase finds ``quantile`` of the
    samples already there, each having waited less than the arc's length.

    Args:
        period_ns: tick period (ns).
        margin_ns: added after the arc's end (ns), for the hand-over to the loop thread.
        window: how many recent arrivals count.
        quantile: share of arrivals that should precede their tick.
        bins: resolution of the folded arrival phases.
        min_gain_ns: a new phase is proposed only if it shortens the wait quantile this much.
    """

    def __init__(
        self,
        period_ns: int = DEFAULT_PERIOD_NS,
        margin_ns: int = 30_000,
        window: int = 2000,
        quantile: float = 0.995,
        bins: int = 50,
        min_gain_ns: int = 100_000,
    ) -> None:
        if not 0.0 < quantile <= 1.0 or bins < 2 or window < 1:
            raise ValueError("PhaseLock needs 0 < quantile <= 1, bins >= 2, window >= 1")
        self.period_ns = period_ns
        self.margin_ns = margin_ns
        self.quantile = quantile
        self.bins = bins
        self.min_gain_ns = min_gain_ns
        self._arrivals: deque[int] = deque(maxlen=window)

    def observe(self, arrival_ns: int) -> None:
        """Note one sample's arrival (monotonic ns); safe from any thread."""
        self._arrivals.append(arrival_ns)

    def __len__(self) -> int:
        return len(self._arrivals)

    def _arcs(self) -> tuple[IntArray, int] | None:
        """Shortest arc length (bins) ending at each bin, and the bin width (ns)."""
        arrivals = np.fromiter(tuple(self._arrivals), dtype=np.int64)
        if arrivals.size == 0:
            return None
        width = self.period_ns // self.bins
        folded = np.minimum((arrivals % self.period_ns) // width, self.bins - 1)
        counts = np.bincount(folded, minlength=self.bins)
        cumulative = np.concatenate(([0], np.cumsum(np.concatenate((counts, counts)))))
        need = max(1, math.ceil(self.quantile * arrivals.size))
        ends = np.arange(self.bins, 2 * self.bins) + 1  # exclusive end index into cumulative
        starts = np.searchsorted(cumulative, cumulative[ends] - need, side="right") - 1
        return (ends - starts).astype(np.int64), width

    def wait_quantile_ns(self, phase_ns: int) -> float:
        """The ``quantile`` of the wait (ns) arrivals would have with ticks at ``phase_ns``."""
        arcs = self._arcs()
        if arcs is None:
            return math.nan
        lengths, width = arcs
        end_bin = ((phase_ns - self.margin_ns) % self.period_ns) // width
        return float(lengths[min(end_bin, self.bins - 1)] * width + self.margin_ns)

    def propose(self, current_phase_ns: int | None, min_samples: int = 100) -> int | None:
        """A better phase (ns modulo the period), or None to keep ``current_phase_ns``."""
        if len(self._arrivals) < min_samples:
            return None
        arcs = self._arcs()
        if arcs is None:
            return None
        lengths, width = arcs
        best = int(np.argmin(lengths))
        phase = ((best + 1) * width + self.margin_ns) % self.period_ns
        if current_phase_ns is None:
            return phase
        gain = self.wait_quantile_ns(current_phase_ns) - (int(lengths[best]) * width)
        gain -= self.margin_ns
        return phase if gain >= self.min_gain_ns else None
