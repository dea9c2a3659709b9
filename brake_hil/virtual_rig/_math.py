"""Elementary functions for laws that run on one state (floats) or on many (arrays).

numpy's ufuncs cost about a microsecond on a Python float, ``math``'s a tenth of that; the
solver calls the laws tens of thousands of times per simulated second on floats.
"""

from __future__ import annotations

import math

import numpy as np

from brake_hil.virtual_rig.laws import Signal


def maximum(value: Signal, floor: float) -> Signal:
    """``max(value, floor)`` elementwise."""
    return max(value, floor) if isinstance(value, float) else np.maximum(value, floor)


def exp(value: Signal) -> Signal:
    """``e^value``."""
    return math.exp(value) if isinstance(value, float) else np.exp(value)


def expm1(value: Signal) -> Signal:
    """``e^value - 1``, accurate near 0."""
    return math.expm1(value) if isinstance(value, float) else np.expm1(value)


def sqrt(value: Signal) -> Signal:
    """Square root."""
    return math.sqrt(value) if isinstance(value, float) else np.sqrt(value)


def tanh(value: Signal) -> Signal:
    """Hyperbolic tangent."""
    return math.tanh(value) if isinstance(value, float) else np.tanh(value)


def absolute(value: Signal) -> Signal:
    """``|value|``."""
    return abs(value) if isinstance(value, float) else np.abs(value)
