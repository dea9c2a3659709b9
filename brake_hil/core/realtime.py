"""Timing of the real-time loops: absolute deadlines, catch-up stepping, self-measurement.

ROS-free (stdlib and numpy), so every piece is testable with a fake clock. The nodes own the
ROS plumbing; the timing and the stepping policy live here:

* :class:`DeadlineLoop` calls a function at absolute deadlines ``t0 + k T`` (monotonic
  clock, ns) on its own thread: a ``time.sleep`` to ``spin`` before the deadline, then a
  short spin that yields the GIL, so the grid never drifts. A tick that wakes a period or
  more late skips the grid slots that have passed (counted) instead of bursting, because one
  tick already steps every sample that arrived (:class:`CatchUpRunner`).
* :class:`PhaseLock` places the grid's phase just after the input samples usually arrive, so
  a sample waits for its tick a fraction of a period rather than a uniform 0-1 period.
* :class:`CatchUpRunner` steps the model once per input sample that arrived since the last
  tick, in arrival order, each prediction carrying its sample's stamp; it watches the input
  (:class:`InputState`) and, in :attr:`HoldMode.HOLD` only, free-runs on the last input while
  the input is silent, flagging those predictions.
* :class:`Histogram` and :class:`LoopStatistics` keep whole-run percentiles in bounded memory
  (1 us bins) beside a window that the diagnostics reset once a report.
* :func:`replay_deadlines` paces a recording by its stamps at a rate factor.

Times: ``*_ns`` are integers in nanoseconds; ``*_us`` floats in microseconds. Monotonic times
(deadlines, arrivals) come from ``time.monotonic_ns``; stamps are ``header.stamp`` (ns since
the epoch).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator
import ctypes
import ctypes.util
from dataclasses import dataclass, field
from enum import Enum
import math
import os
import threading
import time
from typing import NamedTuple, Protocol

import numpy as np
import numpy.typing as npt

NS_PER_S = 1_000_000_000
NS_PER_US = 1_000
DEFAULT_PERIOD_NS = 1_000_000
"""Period of the 1 kHz loops (ns)."""
LATE_TICK_NS = 1_000_000
"""A tick whose wake-up is this late (ns) or more is counted as a late tick."""

IntArray = npt.NDArray[np.int64]
Clock = Callable[[], int]
"""A clock returning nanoseconds (``time.monotonic_ns``)."""
Sleep = Callable[[float], None]
"""A sleep taking seconds (``time.sleep``)."""


# --------------------------------------------------------------------------- statistics


class TimingSummary(NamedTuple):
    """Distribution of one measured duration (us)."""

    samples: int
    median_us: float
    p99_us: float
    p999_us: float
    max_us: float

    def as_dict(self) -> dict[str, float]:
        """Plain mapping for JSON and diagnostics."""
        return {
            "samples": float(self.samples),
            "median_us": self.median_us,
            "p99_us": self.p99_us,
            "p999_us": self.p999_us,
            "max_us": self.max_us,
        }


class Histogram:
    """Durations (ns) counted in 1 us bins up to ``limit_us``, with an exact maximum.

    Values beyond the limit fall in an overflow bin; a quantile that lands there is reported
    as the maximum. Negative values count as zero. Memory: 8 bytes a bin.
    """

    def __init__(self, limit_us: int = 20_000) -> None:
        if limit_us < 1:
            raise ValueError(f"limit_us must be at least 1, got {limit_us}")
        self.limit_us = limit_us
        self._counts: IntArray = np.zeros(limit_us + 1, dtype=np.int64)
        self.count = 0
        self.max_ns = 0

    def add(self, value_ns: int) -> None:
        """Count one duration (ns)."""
        index = value_ns // NS_PER_US
        if index < 0:
            index = 0
        elif index > self.limit_us:
            index = self.limit_us
        self._counts[index] += 1
        self.count += 1
        if value_ns > self.max_ns:
            self.max_ns = value_ns

    def quantile_us(self, q: float) -> float:
        """The ``q`` quantile (0..1) in us: the middle of its bin, NaN when empty."""
        if self.count == 0:
            return math.nan
        cumulative = np.cumsum(self._counts)
        rank = max(1, math.ceil(q * self.count))
        index = int(np.searchsorted(cumulative, rank, side="left"))
        if index >= self.limit_us:
            return self.max_ns / NS_PER_US
        return min(index + 0.5, self.max_ns / NS_PER_US)

    def count_at_least(self, threshold_ns: int) -> int:
        """How many durations were at least ``threshold_ns`` (to the bin, 1 us)."""
        index = min(max(threshold_ns // NS_PER_US, 0), self.limit_us)
        return int(self._counts[index:].sum())

    def summary(self) -> TimingSummary:
        """Median, p99, p99.9 and maximum (us)."""
        if self.count == 0:
            return TimingSummary(0, math.nan, math.nan, math.nan, math.nan)
        cumulative = np.cumsum(self._counts)
        ranks = [max(1, math.ceil(q * self.count)) for q in (0.5, 0.99, 0.999)]
        indices = np.searchsorted(cumulative, ranks, side="left")
        top = self.max_ns / NS_PER_US
        median, p99, p999 = (
            top if index >= self.limit_us else min(index + 0.5, top) for index in indices.tolist()
        )
        return TimingSummary(self.count, median, p99, p999, top)


TIMING_NAMES = ("period_error", "tick_work", "step_time", "input_wait", "latency", "stamp_age")
"""What :class:`LoopStatistics` measures (ns each):

* ``period_error``: wake-up minus deadline of each tick;
* ``tick_work``: wake-up to the end of the tick's work (stepping and publishing);
* ``step_time``: one model step;
* ``input_wait``: arrival of an input sample to the start of the tick that steps it (what the
  tick's phase costs);
* ``latency``: arrival of an input sample to the publication of its prediction;
* ``stamp_age``: the sample's ``header.stamp`` to that publication (wall clock; meaningful when
  stamps are acquisition times on this host's clock).
"""


@dataclass
class LoopCounters:
    """Event counts of a real-time loop (since start)."""

    ticks: int = 0
    late_ticks: int = 0  # woke at least LATE_TICK_NS after the deadline
    overruns: int = 0  # work ended after the next deadline
    ticks_skipped: int = 0  # grid slots passed over after a late wake-up
    phase_shifts: int = 0  # grid moved by the phase lock
    samples: int = 0  # input samples taken
    predictions: int = 0  # predictions made from real samples
    caught_up_ticks: int = 0  # ticks that stepped more than one sample
    caught_up_samples: int = 0  # samples stepped beyond the first of their tick
    max_per_tick: int = 0  # most samples stepped in one tick
    missing_samples: int = 0  # stamp gaps upstream (samples never received)
    stamps_backwards: int = 0  # samples stamped at or before their predecessor
    held: int = 0  # predictions invented in hold mode
    superseded: int = 0  # late samples dropped because hold mode had covered their stamp

    def as_dict(self) -> dict[str, int]:
        """Plain mapping for JSON and diagnostics."""
        return dict(vars(self))


class LoopStatistics:
    """Histograms of :data:`TIMING_NAMES` for the whole run and for the current window.

    The loop thread adds; a reporter thread calls :meth:`take_window` once a report, which
    swaps in a fresh window (a few values racing the swap land in the old one: harmless).
    """

    def __init__(self, limit_us: int = 20_000) -> None:
        self._limit_us = limit_us
        self.total = {name: Histogram(limit_us) for name in TIMING_NAMES}
        self.window = {name: Histogram(limit_us) for name in TIMING_NAMES}
        self.counters = LoopCounters()

    def add(self, name: str, value_ns: int) -> None:
        """Count one duration (ns) of ``name`` in the run and the window."""
        self.total[name].add(value_ns)
        self.window[name].add(value_ns)

    def take_window(self) -> dict[str, TimingSummary]:
        """Summaries of the window since the last call, and start a new window."""
        window, self.window = self.window, {n: Histogram(self._limit_us) for n in TIMING_NAMES}
        return {name: histogram.summary() for name, histogram in window.items()}

    def summary(self) -> dict[str, object]:
        """Whole-run summaries and counters (JSON-ready)."""
        result: dict[str, object] = {
            name: histogram.summary().as_dict() for name, histogram in self.total.items()
        }
        result["late_ticks_over_1ms"] = self.total["period_error"].count_at_least(LATE_TICK_NS)
        result["counters"] = self.counters.as_dict()
        return result


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
    """``SCHED_FIFO`` at ``priority`` for every thread of this process that exists now (the
    middleware's receive threads included; Linux ``/proc/self/task``), and so for the
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
        spin_ns: how long before a deadline sleeping stops and spinning starts (ns).
        statistics: where ``period_error``, ``tick_work``, ticks, late ticks, overruns and
            skipped slots are counted.
        realtime_priority: ``SCHED_FIFO`` priority of the thread (0: normal scheduling).
        idle: called on every turn of the spin before a deadline (work that may run early).
        clock, sleep: injectable for tests.

    An exception raised by ``tick`` stops the loop; it is kept in :attr:`error` and passed
    to ``on_error``.
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
        self._clock = clock
        self._sleep = sleep
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._phase_request: int | None = None
        self._first_deadline_ns: int | None = None
        self._phase: int | None = None
        self.error: BaseException | None = None
        self.realtime = False  # SCHED_FIFO obtained
        self.timer_slack = False  # 1 ns timer slack obtained

    def start(self, first_deadline_ns: int | None = None) -> None:
        """Start the thread; the first deadline defaults to one period from now."""
        self._first_deadline_ns = first_deadline_ns
        self._thread.start()

    def stop(self, timeout_s: float = 2.0) -> None:
        """Ask the loop to stop after its current tick and wait for it (idempotent)."""
        self._stop.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout_s)

    @property
    def running(self) -> bool:
        """True while the thread runs."""
        return self._thread.is_alive()

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
        try:
            self._loop(None)
        except BaseException as err:  # noqa: BLE001 - handed to the owner, the thread ends
            self.error = err
            if self._on_error is not None:
                self._on_error(err)

    def _loop(self, count: int | None) -> None:
        period = self.period_ns
        stats = self.statistics
        counters = stats.counters
        deadline = self._first_deadline_ns
        if deadline is None:
            deadline = self._clock() + period
        self._phase = deadline % period
        slot = 0
        ticks = 0
        while not self._stop.is_set() and (count is None or ticks < count):
            wake = sleep_until(deadline, self.spin_ns, self._clock, self._sleep, self._idle)
            lateness = wake - deadline
            skipped = lateness // period if lateness >= period else 0
            counters.ticks += 1
            counters.ticks_skipped += skipped
            if lateness >= LATE_TICK_NS:
                counters.late_ticks += 1
            stats.add("period_error", lateness)
            self._tick(Tick(slot, deadline, wake, skipped))
            end = self._clock()
            stats.add("tick_work", end - wake)
            ticks += 1
            slot += skipped + 1
            deadline += (skipped + 1) * period
            if end > deadline:
                counters.overruns += 1
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

    def _arcs(self) -> tuple[npt.NDArray[np.int64], int] | None:
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


# --------------------------------------------------------------------------- catching up


class Sample(NamedTuple):
    """One input sample as received."""

    stamp_ns: int  # header.stamp (ns since the epoch)
    value: float  # p_i (Pa)
    arrival_ns: int  # when it was received (monotonic ns)


class Prediction(NamedTuple):
    """The model's outputs for one input sample, stamped like the sample."""

    stamp_ns: int  # the input sample's header.stamp (ns)
    bore_pressure: float  # p_b (Pa)
    block_force: float  # F_k (N)
    caliper_displacement: float  # x_c (m)
    arrival_ns: int  # the input's arrival (monotonic ns); -1 when held
    held: bool  # True when invented by hold mode


class Stepper(Protocol):
    """What :class:`CatchUpRunner` steps: :class:`~brake_hil.core.lti_model.CaliperStepper`."""

    def step(self, pressure: float) -> tuple[float, float, float]:
        """Advance one sample with input ``pressure`` (Pa); return ``(p_b, F_k, x_c)``."""
        ...


class InputState(Enum):
    """Freshness of the model's input."""

    WAITING = "waiting"  # no sample yet
    FRESH = "fresh"  # a sample within late_after
    LATE = "late"  # none for late_after
    SILENT = "silent"  # none for silent_after


class HoldMode(Enum):
    """What the model does while its input is silent."""

    REPORT = "report"  # say so on diagnostics; invent nothing (the default)
    HOLD = "hold"  # free-run on the last input, one step a period, flagged as held


class TickResult(NamedTuple):
    """What one :meth:`CatchUpRunner.tick` produced."""

    predictions: list[Prediction]
    state: InputState
    state_changed: bool


@dataclass
class CatchUpRunner:
    """Steps the model once for every input sample received since the last tick.

    Samples are pushed from the receiving thread (:meth:`push`) and taken by :meth:`tick` on
    the loop thread, all of them, in arrival order: none is skipped, so the live predictions
    equal the batch model on the same samples. Each prediction carries its sample's stamp.
    Stamp gaps (samples lost upstream) and stamps that do not increase are counted; the
    sample is stepped anyway.

    Silence: after ``late_after_ns`` without a sample the state is LATE, after
    ``silent_after_ns`` SILENT. In :attr:`HoldMode.HOLD`, once SILENT the runner invents one
    sample a period at the last input value, stamped one period after the previous
    prediction (so held predictions keep pace with the clock from the last real sample), and
    flags them ``held``. When real samples return, those whose stamp a held prediction has
    already covered are dropped (counted as superseded): the model has moved on in real time.
    """

    stepper: Stepper
    period_ns: int = DEFAULT_PERIOD_NS
    late_after_ns: int = 5_000_000
    silent_after_ns: int = 50_000_000
    hold_mode: HoldMode = HoldMode.REPORT
    statistics: LoopStatistics = field(default_factory=LoopStatistics)
    clock: Clock = time.perf_counter_ns
    _queue: deque[Sample] = field(default_factory=deque, init=False, repr=False)
    _state: InputState = field(default=InputState.WAITING, init=False)
    _last_arrival_ns: int | None = field(default=None, init=False)
    _last_stamp_ns: int | None = field(default=None, init=False)
    _last_value: float = field(default=0.0, init=False)
    _held_since_arrival: int = field(default=0, init=False)  # held steps since a real sample
    _covered_by_hold: bool = field(default=False, init=False)  # last stamp was a held one

    def push(self, sample: Sample) -> None:
        """Queue one received sample (any thread)."""
        self._queue.append(sample)

    @property
    def pending(self) -> int:
        """Samples waiting for the next tick."""
        return len(self._queue)

    @property
    def state(self) -> InputState:
        """Input state at the last tick."""
        return self._state

    def silence_ns(self, now_ns: int) -> int | None:
        """Time since the last real sample arrived (ns), None before the first."""
        return None if self._last_arrival_ns is None else now_ns - self._last_arrival_ns

    def _drain(self) -> Iterator[Sample]:
        queue = self._queue
        while queue:
            yield queue.popleft()

    def tick(self, now_ns: int) -> TickResult:
        """Step every queued sample (or hold); ``now_ns`` is the tick's monotonic time."""
        counters = self.statistics.counters
        predictions: list[Prediction] = []
        stepped = 0
        for sample in self._drain():
            counters.samples += 1
            previous = self._last_stamp_ns
            if previous is not None:
                gap = sample.stamp_ns - previous
                if self._covered_by_hold and gap <= 0:
                    counters.superseded += 1
                    self._last_arrival_ns = sample.arrival_ns
                    self._held_since_arrival = 0
                    continue
                if gap <= 0:
                    counters.stamps_backwards += 1
                elif gap > self.period_ns * 3 // 2 and not self._covered_by_hold:
                    counters.missing_samples += round(gap / self.period_ns) - 1
            predictions.append(self._step(sample.stamp_ns, sample.value, sample.arrival_ns))
            stepped += 1
            self._last_arrival_ns = sample.arrival_ns
            self._held_since_arrival = 0
            self._covered_by_hold = False
        counters.predictions += stepped
        if stepped > 1:
            counters.caught_up_ticks += 1
            counters.caught_up_samples += stepped - 1
        if stepped > counters.max_per_tick:
            counters.max_per_tick = stepped
        state = self._freshness(now_ns)
        if state is InputState.SILENT and self.hold_mode is HoldMode.HOLD:
            predictions.extend(self._hold(now_ns))
        changed = state is not self._state
        self._state = state
        return TickResult(predictions, state, changed)

    def _freshness(self, now_ns: int) -> InputState:
        if self._last_arrival_ns is None:
            return InputState.WAITING
        silence = now_ns - self._last_arrival_ns
        if silence >= self.silent_after_ns:
            return InputState.SILENT
        if silence >= self.late_after_ns:
            return InputState.LATE
        return InputState.FRESH

    def _step(self, stamp_ns: int, value: float, arrival_ns: int) -> Prediction:
        start = self.clock()
        p_b, f_k, x_c = self.stepper.step(value)
        self.statistics.add("step_time", self.clock() - start)
        self._last_stamp_ns = stamp_ns
        self._last_value = value
        return Prediction(stamp_ns, p_b, f_k, x_c, arrival_ns, arrival_ns < 0)

    def _hold(self, now_ns: int) -> list[Prediction]:
        """Held predictions that bring the model level with the clock."""
        assert self._last_arrival_ns is not None and self._last_stamp_ns is not None
        due = (now_ns - self._last_arrival_ns) // self.period_ns
        held = []
        while self._held_since_arrival < due:
            self._held_since_arrival += 1
            stamp = self._last_stamp_ns + self.period_ns
            held.append(self._step(stamp, self._last_value, -1))
            self._covered_by_hold = True
        self.statistics.counters.held += len(held)
        return held


# --------------------------------------------------------------------------- replay pacing


class StampMode(Enum):
    """Which ``header.stamp`` a replayed sample gets."""

    SHIFT = "shift"  # the recorded stamp moved by one offset so the first sample is "now"
    KEEP = "keep"  # the recorded stamp (later loops move by the recording's span)


def replay_deadlines(stamps_ns: IntArray, start_ns: int, rate: float) -> IntArray:
    """Publication times (ns, monotonic) of samples stamped ``stamps_ns``, the first at
    ``start_ns``, at ``rate`` times real time (2.0 plays twice as fast)."""
    if not (math.isfinite(rate) and rate > 0.0):
        raise ValueError(f"rate must be a positive number, got {rate}")
    relative = (stamps_ns - stamps_ns[0]).astype(np.float64) / rate
    deadlines: IntArray = start_ns + np.round(relative).astype(np.int64)
    return deadlines


def loop_span_ns(stamps_ns: IntArray) -> int:
    """Stamp offset (ns) of each further pass of a looped replay: the recording's span plus
    one median sample interval, so stamps keep increasing by one interval across the seam."""
    if stamps_ns.size < 2:
        raise ValueError("a replay needs at least 2 samples")
    interval = int(np.median(np.diff(stamps_ns)))
    return int(stamps_ns[-1] - stamps_ns[0]) + interval
