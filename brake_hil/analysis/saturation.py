"""A transducer held at the end of its range: the extreme value a saturated channel repeats.

A channel read with noise of several quantisation steps repeats its highest or lowest sample
a few times by chance at most. One whose true value went beyond its transducer's range (or
its DAQ's) reads the range's end for as long as it stays beyond: the same value, sample
after sample. Nothing in a recording says the range, so the repeated extreme is what tells.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from brake_hil.types import FloatArray

SATURATED_SAMPLES = 20
"""Samples at exactly one extreme value that mark a channel as held at its range's end
(20 ms at 1 kHz), most of them beside another such sample. A noisy channel repeats its
extreme a few times by chance at most, never in a row."""
REPEATED_SHARE = 0.5
"""A channel whose neighbouring samples are equal this often (away from its extremes) has too
little noise to tell a range's end from a hold or a periodic peak: none is reported."""


class Held(NamedTuple):
    """Where a channel is held (its unit; -inf / inf where it is not) and the share held."""

    low: float
    high: float
    share: float  # of the samples (all, or those a caller counts), at either end


def held_limits(values: FloatArray) -> Held | None:
    """The ends at which ``values`` is held (see the module docstring), or None if none."""
    finite = values[np.isfinite(values)]
    if finite.size < 2:
        return None
    low, high = float(np.min(finite)), float(np.max(finite))
    at_low, at_high = finite == low, finite == high
    touching = at_low[1:] | at_low[:-1] | at_high[1:] | at_high[:-1]
    same = finite[1:] == finite[:-1]
    if low == high or not np.any(~touching) or np.mean(same[~touching]) >= REPEATED_SHARE:
        return None
    ends = []
    for at in (at_low, at_high):
        count = int(np.sum(at))
        in_a_row = int(np.sum(at[1:] & at[:-1]))
        ends.append(count if count >= SATURATED_SAMPLES and 2 * in_a_row >= count else 0)
    if not any(ends):
        return None
    share = sum(ends) / finite.size
    return Held(low if ends[0] else -np.inf, high if ends[1] else np.inf, share)
