"""A hypothesis's held-out log-likelihood and its prior: the terms of the posterior (pure).

:mod:`.posterior` adds them up over every hypothesis; :meth:`.summary.Summary.pair_odds`
compares a pair with its single by them. docs/diagnosis.md.
"""

from __future__ import annotations

import math

from brake_hil.diagnosis.thresholds import EFFECTIVE_SAMPLES, PARAMETER_CHARGE

__all__ = ["log_evidence", "log_prior"]


def log_evidence(
    cost: float,
    parameters: int,
    floor: float,
    samples: float = EFFECTIVE_SAMPLES,
    charge: float = PARAMETER_CHARGE,
) -> float:
    """Held-out log-likelihood of a hypothesis less its parameters' charge (log units).

    Args:
        cost: its held-out mean squared error (a share of the signals' scale squared).
        parameters: the parameters it fits beyond the calibrated baseline's.
        floor: the noise's share of any held-out cost (no model predicts less).
        samples: effectively independent held-out samples.
        charge: the Occam factor of one parameter (log of its prior width over its
            posterior width).
    """
    return -0.5 * samples * math.log(max(cost, floor, 1e-30)) - charge * parameters


def log_prior(size: int, singles: int) -> float:
    """Log prior of one hypothesis of ``size`` effects (0: none or unexplained).

    Each kind (none, a single, a pair, unexplained) has a quarter, shared equally among the
    library's ``singles`` (every one is fitted) and among all pairs of them, whether fitted
    or not (a pair left unfitted is one the single's fit made unlikely).
    """
    shared = {0: 1.0, 1: float(singles), 2: singles * (singles - 1) / 2.0}
    return math.log(0.25 / max(shared.get(size, 1.0), 1.0))
