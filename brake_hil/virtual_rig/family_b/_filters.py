"""Second-order analogue low-pass filters run on sampled channels (family b's acquisition).

A filter is simulated exactly in continuous time on the signal read linearly between samples
(``scipy.signal.lsim``), starting at rest at the first sample, so its lag at low frequency is
its analogue group delay whatever the sample period.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import lsim

from brake_hil.types import FloatArray

__all__ = ["FILTER_KINDS", "dc_group_delay_factor", "low_pass", "transport_delay"]

FILTER_KINDS = ("bessel", "butterworth")
"""Second-order low-pass prototypes: Bessel (flat group delay), Butterworth (flat gain)."""

_DAMPING = {"bessel": math.sqrt(3.0) / 2.0, "butterworth": math.sqrt(2.0) / 2.0}
"""Damping ratio zeta of each prototype's pole pair, on its natural frequency."""
_NATURAL_OVER_CUTOFF = {"bessel": 1.0 / 0.7862, "butterworth": 1.0}
"""Natural frequency over the -3 dB cut-off frequency of each prototype."""


def dc_group_delay_factor(kind: str) -> float:
    """``tau w_c`` (-): group delay at DC times the -3 dB cut-off (rad/s) of ``kind``.

    A 2nd-order low-pass ``w_n^2 / (s^2 + 2 zeta w_n s + w_n^2)`` lags by ``2 zeta / w_n``.
    """
    return 2.0 * _DAMPING[kind] / _NATURAL_OVER_CUTOFF[kind]


def low_pass(kind: str, cutoff: float, time: FloatArray, values: FloatArray) -> FloatArray:
    """``values`` (sampled at ``time``, s) through a 2nd-order ``kind`` low-pass.

    ``cutoff`` is the -3 dB frequency (rad/s); the filter starts at rest on ``values[0]``.
    """
    natural = cutoff * _NATURAL_OVER_CUTOFF[kind]
    damping = _DAMPING[kind]
    # state x = (y, y'/w_n): y'' = w_n^2 (u - y) - 2 zeta w_n y'
    a = np.array([[0.0, natural], [-natural, -2.0 * damping * natural]])
    b = np.array([[0.0], [natural]])
    c = np.array([[1.0, 0.0]])
    d = np.array([[0.0]])
    start = np.array([values[0], 0.0])
    _, filtered, _ = lsim((a, b, c, d), values, time - time[0], X0=start, interp=True)
    return np.asarray(filtered, dtype=float)


def transport_delay(samples: int, values: FloatArray) -> FloatArray:
    """``values`` delayed by a whole number of ``samples`` (the first value held before)."""
    if samples <= 0:
        return np.asarray(values, dtype=float)
    delayed = np.empty_like(values, dtype=float)
    delayed[:samples] = values[0]
    delayed[samples:] = values[:-samples]
    return delayed
