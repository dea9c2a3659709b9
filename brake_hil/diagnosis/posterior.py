"""The posterior share of every fitted hypothesis (pure): the runner-up, a pair's odds.

Each hypothesis (none: the calibrated baseline; each single; each pair; ``unexplained``: the
best generic form of the baseline's misfit) is scored by its held-out log-likelihood under a
Gaussian residual of unknown variance, ``-n/2 log(cost)``, where ``n`` is the number of
effectively independent held-out samples (``EFFECTIVE_SAMPLES``; the residuals are
correlated, so far fewer than the samples recorded), less the Occam factor of its fitted
parameters (Laplace's approximation: ``PARAMETER_CHARGE`` per parameter, the log of a
parameter's prior width over the width the recording pins it to). A cost under the noise's share
(:attr:`.summary.Summary.floor_cost`) counts as that share: no model predicts the held-out
noise. The posterior share of a hypothesis is its likelihood times its prior over the sum
of all; the prior gives each kind (none, a single, a pair, unexplained) a quarter, shared
equally among the library's singles, and among all pairs of them. It names the runner-up
and weighs a pair against its single; the verdict's confidence is :mod:`.reliability`'s.
docs/diagnosis.md.
"""

from __future__ import annotations

from dataclasses import dataclass
import math

from brake_hil.diagnosis.likelihood import log_evidence, log_prior
from brake_hil.diagnosis.summary import Hypothesis, Summary
from brake_hil.diagnosis.thresholds import EFFECTIVE_SAMPLES, FORM_PARAMETERS, PARAMETER_CHARGE

__all__ = ["NONE", "UNEXPLAINED", "Posterior", "log_evidence", "log_prior", "posterior"]

NONE: tuple[str, ...] = ()
"""The hypothesis that the calibrated baseline explains the recording."""
UNEXPLAINED: tuple[str, ...] = ("unexplained",)
"""A real misfit no library effect identifies (its best generic form, or a fit set aside)."""


@dataclass(frozen=True)
class Posterior:
    """The posterior share of each hypothesis (``()`` none, ``("unexplained",)``, effects)."""

    shares: dict[tuple[str, ...], float]

    def of(self, effects: tuple[str, ...]) -> float:
        """The posterior share of the hypothesis naming exactly ``effects`` (0 if unscored)."""
        return self.shares.get(tuple(effects), 0.0)

    def with_effect(self, name: str, size: int) -> float:
        """The share of the hypotheses of ``size`` effects that hold ``name``."""
        return sum(p for e, p in self.shares.items() if len(e) == size and name in e)

    def best(self) -> tuple[str, ...]:
        """The hypothesis of the largest share."""
        return max(self.shares, key=lambda e: self.shares[e])


def posterior(
    summary: Summary, samples: float = EFFECTIVE_SAMPLES, charge: float = PARAMETER_CHARGE
) -> Posterior:
    """The posterior share of each hypothesis of ``summary`` (they sum to one).

    A hypothesis that cannot be named (implausible fitted values, or set aside by a physics
    check) is evidence of a misfit the library does not identify: its likelihood joins
    ``unexplained``'s (scored as its best generic form, ``FORM_PARAMETERS`` parameters).
    """
    floor = summary.floor_cost
    scores: dict[tuple[str, ...], float] = {
        NONE: log_evidence(summary.baseline_cost, 0, floor, samples, charge)
    }
    unnamed = [
        log_evidence(
            summary.baseline_cost / max(summary.form_gain, 1.0),
            FORM_PARAMETERS,
            floor,
            samples,
            charge,
        )
    ]
    for h in (*summary.singles, *summary.pairs):
        score = log_evidence(h.held_out_cost, h.parameters, floor, samples, charge)
        if _nameable(summary, h):
            scores[h.effects] = score
        else:
            unnamed.append(score)
    scores[UNEXPLAINED] = _log_sum(unnamed)
    count = len(summary.singles)
    scores = {
        e: s + log_prior(len(e) if e != UNEXPLAINED else 0, count) for e, s in scores.items()
    }
    total = _log_sum(list(scores.values()))
    return Posterior({e: math.exp(s - total) for e, s in scores.items()})


def _nameable(summary: Summary, h: Hypothesis) -> bool:
    """Plausible fitted values, not set aside by a physics check."""
    return h.plausible and "+".join(h.effects) not in summary.stand_ins


def _log_sum(values: list[float]) -> float:
    top = max(values)
    return top + math.log(sum(math.exp(v - top) for v in values))
