"""The trend test of a rig's series: a robust line and whether it is beyond doubt.

A Theil-Sen line over the run number (:func:`scipy.stats.theilslopes`) and the Mann-Kendall
test, widened for day-to-day correlation; :mod:`.trend` says what a series' line means.
"""

from __future__ import annotations

import math
from typing import Final, NamedTuple

import numpy as np
from scipy import stats

from brake_hil.types import FloatArray

__all__ = ["CONFIDENCE", "SIGNIFICANCE", "TREND_RUNS"]

CONFIDENCE: Final = 0.99
"""Confidence of the Theil-Sen interval of a slope that must exclude 0."""
SIGNIFICANCE: Final = 0.001
"""Largest p-value of the trend test (:func:`_trend_p_value`). A rig has about 15 series, so
the test is strict: at 0.002 steady synthetic fleets got a line in 1.3 %, at 0.001 in 0.65 %
(with the size thresholds below; a 95 % interval of the slope in its place: 19 %)."""


class _Fit(NamedTuple):
    slope: float
    interval: tuple[float, float]
    intercept: float
    p_value: float
    significant: bool
    first: float  # the line at the first used run
    last: float  # the line at the last used run


def _fit(x: FloatArray, y: FloatArray) -> _Fit:
    """Theil-Sen line and Kendall's test of ``y`` against the run number ``x``."""
    fitted = stats.theilslopes(y, x, alpha=CONFIDENCE)
    slope, intercept = float(fitted.slope), float(fitted.intercept)
    low, high = float(fitted.low_slope), float(fitted.high_slope)
    p_value = _trend_p_value(y, y - slope * x)
    significant = (low > 0.0 or high < 0.0) and p_value < SIGNIFICANCE
    return _Fit(
        slope,
        (low, high),
        intercept,
        p_value,
        significant,
        intercept + slope * float(x[0]),
        intercept + slope * float(x[-1]),
    )


def _trend_p_value(y: FloatArray, residuals: FloatArray) -> float:
    """Two-sided p-value of the Mann-Kendall trend test of ``y`` (in run order).

    The variance of Kendall's S is widened for day-to-day correlation: by
    ``1 + 2 (n - 3) / n * rho_1``, ``rho_1`` the lag-1 autocorrelation of the ranks of the
    detrended series when positive (Hamed and Rao, J. Hydrol. 204, 1998, eq. 18 at lag 1).
    Ties in ``y`` count 0 in S; a continuity correction of 1.
    """
    n = y.size
    signs = np.sign(y[None, :] - y[:, None])
    S = float(np.triu(signs, 1).sum())
    _, ties = np.unique(y, return_counts=True)
    variance = (n * (n - 1) * (2 * n + 5) - float((ties * (ties - 1) * (2 * ties + 5)).sum())) / 18
    ranks = stats.rankdata(residuals)
    centred = ranks - ranks.mean()
    denominator = float(centred @ centred)
    rho = float(centred[1:] @ centred[:-1]) / denominator if denominator > 0 else 0.0
    variance *= 1.0 + 2.0 * (n - 3) / n * max(rho, 0.0)
    if variance <= 0.0 or S == 0.0:
        return 1.0
    z = (abs(S) - 1.0) / math.sqrt(variance)
    return float(2.0 * stats.norm.sf(z))


def _runs_for_a_trend(most: int = 200) -> int:
    """The fewest runs for which a perfectly monotone series passes the trend test."""
    for n in range(3, most):
        x = np.arange(n, dtype=float)
        if _fit(x, x).significant:
            return n
    raise AssertionError("the trend test never passes")  # pragma: no cover


TREND_RUNS: Final = _runs_for_a_trend()
"""Fewest runs the trend test can fire on (8 at p < 0.001): fewer are too few for a trend."""


def _no_fit() -> _Fit:
    nan = math.nan
    return _Fit(nan, (nan, nan), nan, nan, False, nan, nan)
