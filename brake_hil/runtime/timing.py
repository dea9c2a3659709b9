"""Clocks and whole-run timing statistics of the real-time loops (ns integers, us floats)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
import math
from typing import NamedTuple

import numpy as np

from brake_hil.types import IntArray

NS_PER_S = 1_000_000_000
NS_PER_US = 1_000
DEFAULT_PERIOD_NS = 1_000_000
"""Period of the 1 kHz loops (ns)."""
LATE_TICK_NS = 1_000_000
"""A tick whose wake-up is this late (ns) or more is counted as a late tick."""

Clock = Callable[[], int]
"""A clock returning nanoseconds (``time.monotonic_ns``)."""
Sleep = Callable[[float], None]
"""A sleep taking seconds (``time.sleep``)."""


# --------------------------------------------------------------------------- statistics


class TimingSummary(NamedTuple):
    """Distribution of one measured duration (us).

    ``ceiling_us`` is the top of what the histogram resolves: a quantile at or past it is only
    known to be "over" it (:func:`format_us`), never printed as a value.
    """

    samples: int
    median_us: float
    p99_us: float
    p999_us: float
    max_us: float
    ceiling_us: float = math.inf

    def as_dict(self) -> dict[str, float]:
        """Plain mapping for JSON and diagnostics."""
        return {
            "samples": float(self.samples),
            "median_us": self.median_us,
            "p99_us": self.p99_us,
            "p999_us": self.p999_us,
            "max_us": self.max_us,
            "ceiling_us": self.ceiling_us,
        }

    def text(self, name: str) -> str:
        """One quantile (``median``, ``p99``, ``p999``, ``max``) for people: :func:`format_us`."""
        return format_us(getattr(self, f"{name}_us"), self.ceiling_us)


def format_us(value_us: float, ceiling_us: float = math.inf) -> str:
    """A duration quantile for people: ``"250 us"``, ``"25.3 ms"``, ``"3.2 s"``, ``"n/a"``.

    At or past ``ceiling_us`` (beyond what the histogram resolves) it says
    ``"over 100000 ms"`` rather than a figure.
    """
    if not math.isfinite(value_us):
        return "n/a"
    if value_us >= ceiling_us:
        return f"over {ceiling_us / 1000:.0f} ms"
    if value_us < 1_000:
        return f"{value_us:.0f} us"
    if value_us < 1_000_000:
        return f"{value_us / 1000:.1f} ms"
    return f"{value_us / 1e6:.2f} s"


LOG_BIN_RATIO = 1.01
"""Width of the log-spaced bins past the 1 us bins: a quantile there is within 0.5 %."""
TOP_US = 100_000_000
"""The top of what a :class:`Histogram` resolves (us): 100 s."""


class Histogram:
    """Durations (ns) in 1 us bins up to ``limit_us``, log-spaced bins to 100 s, exact maximum.

    Quantiles are true quantiles over the whole range: to the us below ``limit_us``, within
    0.5 % (the middle of a bin ``LOG_BIN_RATIO`` wide) up to :data:`TOP_US`. Past that they are
    reported as :data:`TOP_US`, flagged by the summary's ``ceiling_us``. Negative values count
    as zero. Memory: 8 bytes a bin (about 21 000 bins).
    """

    def __init__(self, limit_us: int = 20_000) -> None:
        if limit_us < 1:
            raise ValueError(f"limit_us must be at least 1, got {limit_us}")
        self.limit_us = limit_us
        top = max(TOP_US, limit_us + 1)
        steps = math.ceil(math.log(top / limit_us) / math.log(LOG_BIN_RATIO))
        # edges (us) of the log bins: limit_us * ratio**k, k = 0..steps; the last bin: overflow
        self._edges_us = limit_us * LOG_BIN_RATIO ** np.arange(steps + 1, dtype=np.float64)
        self._log_scale = 1.0 / math.log(LOG_BIN_RATIO)
        self._counts: IntArray = np.zeros(limit_us + steps + 1, dtype=np.int64)
        self.ceiling_us = float(self._edges_us[-1])
        self.count = 0
        self.max_ns = 0

    def _index(self, value_ns: int) -> int:
        micro = value_ns // NS_PER_US
        if micro < self.limit_us:
            return max(int(micro), 0)
        step = int(math.log(value_ns / (NS_PER_US * self.limit_us)) * self._log_scale)
        return self.limit_us + min(step, self._edges_us.size - 1)

    def add(self, value_ns: int) -> None:
        """Count one duration (ns)."""
        self._counts[self._index(value_ns)] += 1
        self.count += 1
        if value_ns > self.max_ns:
            self.max_ns = value_ns

    def _value_us(self, index: int) -> float:
        """The value (us) a quantile in bin ``index`` is given: its middle, at most the max."""
        top = self.max_ns / NS_PER_US
        if index < self.limit_us:
            return min(index + 0.5, top)
        step = index - self.limit_us
        if step >= self._edges_us.size - 1:
            return self.ceiling_us  # beyond the range: "over" it
        low, high = self._edges_us[step], self._edges_us[step + 1]
        return float(min(math.sqrt(low * high), top))

    def quantile_us(self, q: float) -> float:
        """The ``q`` quantile (0..1) in us; :attr:`ceiling_us` past the range; NaN when empty."""
        if self.count == 0:
            return math.nan
        cumulative = np.cumsum(self._counts)
        rank = max(1, math.ceil(q * self.count))
        if rank >= self.count:
            return self.max_ns / NS_PER_US  # the largest: exact
        return self._value_us(int(np.searchsorted(cumulative, rank, side="left")))

    def count_at_least(self, threshold_ns: int) -> int:
        """How many durations were at least ``threshold_ns`` (to the bin)."""
        return int(self._counts[self._index(threshold_ns) :].sum())

    def summary(self) -> TimingSummary:
        """Median, p99, p99.9 and maximum (us), with the resolved range's ceiling."""
        if self.count == 0:
            return TimingSummary(0, math.nan, math.nan, math.nan, math.nan, self.ceiling_us)
        cumulative = np.cumsum(self._counts)
        ranks = [max(1, math.ceil(q * self.count)) for q in (0.5, 0.99, 0.999)]
        indices = np.searchsorted(cumulative, ranks, side="left").tolist()
        median, p99, p999 = (self._value_us(index) for index in indices)
        return TimingSummary(
            self.count, median, p99, p999, self.max_ns / NS_PER_US, self.ceiling_us
        )


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
    nonfinite_inputs: int = 0  # samples with a NaN/inf value: not stepped (the input held)
    nonfinite_states: int = 0  # steps whose outputs were not finite: not published
    state_resets: int = 0  # restarts from the equilibrium after a non-finite state

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
