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
* :func:`loopback_environment` and :func:`security_problem` (:mod:`.middleware`): the DDS
  environment of every path that starts a node (loopback profile, security plugins).

Times: ``*_ns`` are integers in nanoseconds; ``*_us`` floats in microseconds. Monotonic times
(deadlines, arrivals) come from ``time.monotonic_ns``; stamps are ``header.stamp`` (ns since
the epoch).
"""

from __future__ import annotations

from brake_hil.live.model import Stepper
from brake_hil.runtime.catch_up import (
    CatchUpRunner,
    HoldMode,
    InputState,
    Prediction,
    Sample,
    StampMode,
    TickResult,
    loop_span_ns,
    replay_deadlines,
)
from brake_hil.runtime.deadline_loop import (
    DeadlineLoop,
    PhaseLock,
    Tick,
    set_process_realtime_priority,
    set_realtime_priority,
    set_timer_slack,
    sleep_until,
)
from brake_hil.runtime.middleware import (
    loopback_environment,
    loopback_profile_path,
    security_problem,
)
from brake_hil.runtime.timing import (
    DEFAULT_PERIOD_NS,
    LATE_TICK_NS,
    NS_PER_S,
    NS_PER_US,
    TIMING_NAMES,
    Histogram,
    LoopCounters,
    LoopStatistics,
    TimingSummary,
)

__all__ = [
    "DEFAULT_PERIOD_NS",
    "LATE_TICK_NS",
    "NS_PER_S",
    "NS_PER_US",
    "TIMING_NAMES",
    "CatchUpRunner",
    "DeadlineLoop",
    "Histogram",
    "HoldMode",
    "InputState",
    "LoopCounters",
    "LoopStatistics",
    "PhaseLock",
    "Prediction",
    "Sample",
    "StampMode",
    "Stepper",
    "Tick",
    "TickResult",
    "TimingSummary",
    "loop_span_ns",
    "loopback_environment",
    "loopback_profile_path",
    "replay_deadlines",
    "security_problem",
    "set_process_realtime_priority",
    "set_realtime_priority",
    "set_timer_slack",
    "sleep_until",
]
