"""The pieces of a rig's trend: how each value and effect is said, and one series of it."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Final, NamedTuple

import numpy as np

from brake_hil.physics.calibrated_values import VALUE_LABELS
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.types import BoolArray, FloatArray, IntArray

__all__ = ["ADVICE", "Advice", "Movement", "Series", "advice"]


class Advice(NamedTuple):
    """How a value or effect is said, and what its move points to on the rig."""

    words: str  # e.g. "caliper stiffness"
    cause: str  # e.g. "check the caliper mounting"


_NO_CAUSE = "see the diagnosis report of the last run"
"""What an effect whose catalogue entry names no cause points to."""


class _Advice(Mapping[str, Advice]):
    """Every calibrated value's and library effect's advice, as the catalogue is when read.

    A value's from :data:`~brake_hil.physics.calibrated_values.VALUE_LABELS`, an effect's from
    its catalogue entry (``label``, else its title; ``cause``).
    """

    def __getitem__(self, name: str) -> Advice:
        if name in VALUE_LABELS:
            label = VALUE_LABELS[name]
            return Advice(label.words, label.cause)
        item = CATALOGUE[name]
        return Advice(item.label or item.title, item.cause or _NO_CAUSE)

    def __iter__(self) -> Iterator[str]:
        yield from VALUE_LABELS
        yield from (name for name in CATALOGUE if name not in VALUE_LABELS)

    def __len__(self) -> int:
        return sum(1 for _ in self)


ADVICE: Final[Mapping[str, Advice]] = _Advice()
"""Per calibrated value and effect (a test holds it to the calibration and the catalogue);
the diagnosis report's ``RIG_CHECKS`` says in more words what to look at for an effect."""


def advice(name: str) -> Advice:
    """How ``name`` is said: its :data:`ADVICE`, or its name in words for an unknown one."""
    if name in VALUE_LABELS or name in CATALOGUE:
        return ADVICE[name]
    return Advice(name.replace("_", " "), _NO_CAUSE)


class Movement(StrEnum):
    """What a series did."""

    STEADY = "steady"  # no trend beyond doubt, over enough runs to test one
    OUTSIDE = "outside"  # a run's value far outside its band, said at once
    DRIFT = "drift"  # a value moved along a significant trend
    OFFSET = "offset"  # a value outside its band throughout, without a drift
    GREW = "grew"  # an effect grew and the verdicts came to name it
    TOO_FEW = "too_few"  # fewer than TREND_RUNS usable runs: no trend test


@dataclass(frozen=True)
class Series:
    """One calibrated value or one effect of a rig across its runs, and its trend."""

    name: str  # calibration value or effect name
    kind: str  # "value" or "effect"
    runs: IntArray  # each point's run number in the rig's time order (0 = first)
    times_ns: IntArray  # each point's recording start (ns since the epoch; -1: unknown)
    values: FloatArray  # value: multiplier over the rig file's; effect: log10 improvement
    used: BoolArray  # points the trend is fitted on (value: identified in that run)
    named: BoolArray  # effect: the run's verdict names it (value: all False)
    band: tuple[float, float] | None  # value: multiplier band (exp(-sigma), exp(sigma))
    slope: float  # per run: of ln multiplier (value) or log10 improvement (effect); NaN
    interval: tuple[float, float]  # CONFIDENCE interval of the slope (per run)
    intercept: float  # of the line at run 0, in the slope's units
    p_value: float  # Kendall's tau test of the trend (NaN when too few)
    movement: Movement
    finding: str | None  # the line in plain words (drift, offset, grew); None otherwise
    outside: tuple[int, ...] = ()  # value: runs at least OUTSIDE_SIGMA tolerances off
    stand_in: bool = False  # value: its move is the LTI model's alone (``_back_within``)
    # value: the effect the improved model carried, when the values are that model's
    modelled: str | None = None

    @property
    def words(self) -> str:
        """How the value or effect is said (:data:`ADVICE`)."""
        return advice(self.name).words

    def line(self) -> FloatArray:
        """The fitted trend at each used run, in the units of :attr:`values`."""
        level = self.intercept + self.slope * self.runs[self.used].astype(float)
        return np.exp(level) if self.kind == "value" else level
