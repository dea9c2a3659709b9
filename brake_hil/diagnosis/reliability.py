"""The verdict's confidence: how often verdicts like it were right (pure; replayable).

A verdict is described by three numbers of its :class:`.summary.Summary`
(:class:`VerdictTraits`): its kind (none, ``unexplained``, one effect, two), its lead (the
log of its held-out cut over that of the best hypothesis sharing none of its effects; for a
named one, no more than its smallest decision margin: a pair with a second effect, a pair
swapping its second effect, a generic form) and whether a rule doubts it in words
(``Verdict.capped``). Its confidence is a logistic function of
them, fitted by maximum likelihood to right and wrong verdicts of contract-spanning cases
of family a (``benchmarks/bench_confidence.py``) and judged on families b and c, which no
weight saw. The posterior share (:mod:`.posterior`) ranks the hypotheses; on recordings
whose physics the candidates only approximate it is sure of the wrong one as often as of
the right one, so it is not the confidence. docs/diagnosis.md.
"""

from __future__ import annotations

from dataclasses import dataclass
import math

from brake_hil.diagnosis.candidates import candidate
from brake_hil.diagnosis.summary import Summary, ratio

__all__ = [
    "CAPPED_LOG_ODDS",
    "KIND_LOG_ODDS",
    "LEAD_LIMITS",
    "LEAD_LOG_ODDS",
    "VerdictTraits",
    "holds",
    "reliability",
    "traits",
]

KIND_LOG_ODDS: dict[str, float] = {
    "none": -0.19,
    "unexplained": 0.15,
    "single": 1.22,
    "pair": -0.64,
}
"""Log odds of a verdict of each kind being right at lead 0, not doubted.

Fitted (``benchmarks/bench_confidence.py``, 140 family-a verdicts): a single is right more
often than a pair (one member lost or added) or a none (weak effects under the noise).
docs/diagnosis.md.
"""
LEAD_LOG_ODDS = 0.38
"""Log odds gained per unit of lead (log held-out cut over the best rival's). Fitted."""
CAPPED_LOG_ODDS = -1.54
"""Log odds of a verdict a rule doubts (``Verdict.capped``) against one it does not. Fitted."""
LEAD_LIMITS = (-3.0, 5.0)
"""A verdict's lead is held within these (log units: 20 times under to 150 times over the rival's
cut), so a lead far beyond those of the verdicts fitted on is not carried past them."""


@dataclass(frozen=True)
class VerdictTraits:
    """What the confidence is read from (:func:`traits`)."""

    kind: str  # "none", "unexplained", "single", "pair"
    lead: float  # log held-out cut over the best rival's, within LEAD_LIMITS
    capped: bool  # a rule doubts it (Verdict.capped)


def traits(
    summary: Summary, effects: tuple[str, ...], capped: bool, margin: float = 0.0
) -> VerdictTraits:
    """The traits of the verdict naming ``effects`` (``()`` none, ``("unexplained",)``).

    ``capped``: a rule doubts it in words; ``margin``: its smallest decision margin (log
    units, ``Verdict.margin``), which a named verdict's lead is held under.

    Its own cut: none's is 1, ``unexplained``'s the best generic form's
    (:attr:`Summary.form_gain`), a named hypothesis's its held-out cut. Its rivals: every
    fitted hypothesis sharing none of its effects and not holding it as a special case, and
    none (a cut of 1) for a named one.
    """
    fitted = {
        h.effects: ratio(summary.baseline_cost, h.held_out_cost)
        for h in (*summary.singles, *summary.pairs)
    }
    if effects == ():
        kind, own = "none", 1.0
    elif effects == ("unexplained",):
        kind, own = "unexplained", max(summary.form_gain, 1.0)
    else:
        kind, own = ("single" if len(effects) == 1 else "pair"), fitted.get(effects, 1.0)
    rivals = [
        cut for e, cut in fitted.items() if not set(e) & set(effects) and not holds(e, effects)
    ]
    if effects:
        rivals.append(1.0)
    low, high = LEAD_LIMITS
    lead = math.log(own) - math.log(max(rivals, default=1.0))
    if kind in ("single", "pair"):
        lead = min(lead, margin)
    return VerdictTraits(kind, min(max(lead, low), high), capped)


def holds(effects: tuple[str, ...], chosen: tuple[str, ...]) -> bool:
    """A single whose law holds the single ``chosen`` as a special case (``contains``).

    It is no rival of ``chosen``: fitting as well, it is ``chosen`` (the groove at ``a = 0``
    is plain stick-slip; what it resolves of its asymmetry is said apart, ``groove.py``).
    """
    return len(effects) == len(chosen) == 1 and chosen[0] in candidate(effects[0]).contains


def reliability(
    t: VerdictTraits,
    kind_log_odds: dict[str, float] | None = None,
    lead_log_odds: float = LEAD_LOG_ODDS,
    capped_log_odds: float = CAPPED_LOG_ODDS,
) -> float:
    """The probability that a verdict of traits ``t`` is right (the weights as shipped)."""
    kinds = KIND_LOG_ODDS if kind_log_odds is None else kind_log_odds
    z = kinds[t.kind] + lead_log_odds * t.lead + (capped_log_odds if t.capped else 0.0)
    return 1.0 / (1.0 + math.exp(-z))
