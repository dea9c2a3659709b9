"""Stepping the model once per input sample that arrived; replay pacing by stamps.

The stepping is :class:`CatchUpRunner`.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from enum import Enum
import math
import time
from typing import NamedTuple

import numpy as np

from brake_hil.live.model import Stepper
from brake_hil.runtime.timing import DEFAULT_PERIOD_NS, Clock, LoopStatistics
from brake_hil.types import IntArray

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
    Stamp gaps (samples lost upstream) are counted and the sample is stepped. A sample stamped
    at or before the last stepped one is counted (``stamps_backwards``) and not stepped: no two
    predictions ever carry one stamp.

    Non-finite values never reach the model's state. A sample whose value is NaN or infinite
    is counted (``nonfinite_inputs``) and not stepped: the model holds its last good state
    and input, and :attr:`last_nonfinite_stamp_ns` names it. A step whose outputs are not
    finite (a finite but absurd input) is counted (``nonfinite_states``) and not published;
    the stepper is replaced by a fresh one from ``restart``, so the next good input starts
    the model again from the equilibrium at that input (counted ``state_resets``).

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
    restart: Callable[[], Stepper] | None = None  # a fresh stepper (else ``stepper.reset()``)
    last_nonfinite_stamp_ns: int | None = field(default=None, init=False)  # last NaN/inf p_i
    _needs_reset: bool = field(default=False, init=False)
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
                    self._last_arrival_ns = sample.arrival_ns
                    continue
                if gap > self.period_ns * 3 // 2 and not self._covered_by_hold:
                    counters.missing_samples += round(gap / self.period_ns) - 1
            self._last_arrival_ns = sample.arrival_ns
            if not math.isfinite(sample.value):
                counters.nonfinite_inputs += 1
                self.last_nonfinite_stamp_ns = self._last_stamp_ns = sample.stamp_ns
                self._covered_by_hold = False
                continue
            prediction = self._step(sample.stamp_ns, sample.value, sample.arrival_ns)
            if prediction is None:
                continue
            predictions.append(prediction)
            stepped += 1
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

    def _step(self, stamp_ns: int, value: float, arrival_ns: int) -> Prediction | None:
        """One step; None (and a restart due) when its outputs are not finite."""
        if self._needs_reset:
            self._needs_reset = False
            self.statistics.counters.state_resets += 1
        start = self.clock()
        p_b, f_k, x_c = self.stepper.step(value)
        self.statistics.add("step_time", self.clock() - start)
        self._last_stamp_ns = stamp_ns
        if not (math.isfinite(p_b) and math.isfinite(f_k) and math.isfinite(x_c)):
            self.statistics.counters.nonfinite_states += 1
            self._restart()
            return None
        self._last_value = value
        return Prediction(stamp_ns, p_b, f_k, x_c, arrival_ns, arrival_ns < 0)

    def _restart(self) -> None:
        """Forget the model's state: the next step starts from its equilibrium."""
        if self.restart is not None:
            self.stepper = self.restart()
        else:
            reset = getattr(self.stepper, "reset", None)
            if reset is None:
                raise TypeError("a stepper without reset() needs CatchUpRunner.restart")
            reset()
        self._needs_reset = True

    def _hold(self, now_ns: int) -> list[Prediction]:
        """Held predictions that bring the model level with the clock."""
        assert self._last_arrival_ns is not None and self._last_stamp_ns is not None
        due = (now_ns - self._last_arrival_ns) // self.period_ns
        held = []
        while self._held_since_arrival < due:
            self._held_since_arrival += 1
            stamp = self._last_stamp_ns + self.period_ns
            prediction = self._step(stamp, self._last_value, -1)
            self._covered_by_hold = True
            if prediction is not None:
                held.append(prediction)
        self.statistics.counters.held += len(held)
        return held


# --------------------------------------------------------------------------- replay pacing


class StampMode(Enum):
    """Which ``header.stamp`` a replayed sample gets."""

    SHIFT = "shift"  # the recorded stamp moved by one offset so the first sample is "now"
    KEEP = "keep"  # the recorded stamp (later loops move by the recording's span)


def replay_deadlines(stamps_ns: IntArray, start_ns: int, rate: float) -> IntArray:
    """Publication times (ns, monotonic) of samples stamped ``stamps_ns``.

    The first at ``start_ns``, at ``rate`` times real time (2.0 plays twice as fast).
    """
    if not (math.isfinite(rate) and rate > 0.0):
        raise ValueError(f"rate must be a positive number, got {rate}")
    relative = (stamps_ns - stamps_ns[0]).astype(np.float64) / rate
    deadlines: IntArray = start_ns + np.round(relative).astype(np.int64)
    return deadlines


def loop_span_ns(stamps_ns: IntArray) -> int:
    """Stamp offset (ns) of each further pass of a looped replay.

    The recording's span plus one median sample interval, so stamps keep increasing by one
    interval across the seam.
    """
    if stamps_ns.size < 2:
        raise ValueError("a replay needs at least 2 samples")
    interval = int(np.median(np.diff(stamps_ns)))
    return int(stamps_ns[-1] - stamps_ns[0]) + interval
