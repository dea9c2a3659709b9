"""A hypothesis a rival ties with: named, doubted, unless that rival's effect is (pure).

A physics check sets a hypothesis aside when a rival fitted in its place explains about as
well (:func:`.physics_checks.rival_check`). Where the rival is a library effect's physics
(a late ``p_i`` is a ``sensor_delay`` with every output leading,
:attr:`.candidates.base.Rival.stands_for`) and the hypothesis passed every other check, the
recording does not tell the two apart (:attr:`.summary.Summary.not_told_from`). Dropping the
hypothesis then left either nothing named over a misfit it explains (a strong creeping hose
called none) or the rival's effect named as sure as if nothing tied with it (a hose called a
late ``p_i`` at 0.76). So (:func:`untie`): a verdict naming that effect is doubted in words;
a verdict naming nothing (none, ``unexplained``) is decided again with the tie lifted, and
the tied hypothesis, when it is then named, is named doubted. docs/diagnosis.md.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from brake_hil.diagnosis.reliability import reliability, traits
from brake_hil.diagnosis.summary import Summary
from brake_hil.diagnosis.verdict_record import NOT_TOLD_APART, Verdict

__all__ = ["NOT_TOLD_APART", "tied_with", "untie"]


def untie(summary: Summary, verdict: Verdict, rules: Callable[[Summary], Verdict]) -> Verdict:
    """``verdict`` (of ``rules`` on ``summary``) with its ties said (see the module)."""
    ties = summary.not_told_from
    if len(verdict.effects) == 1 and verdict.effects[0] in ties.values():
        return _doubted(summary, verdict)
    if verdict.effects not in ((), ("unexplained",)):
        return verdict
    for key in ties:
        stand_ins = {k: v for k, v in summary.stand_ins.items() if k != key}
        lifted = replace(summary, stand_ins=stand_ins, not_told_from={})
        again = rules(lifted)
        if "+".join(again.effects) == key:
            return _doubted(lifted, again)
    return verdict


def tied_with(
    summary: Summary, effects: tuple[str, ...], capped: str | None
) -> tuple[str, str] | None:
    """What a tie-doubted verdict (``effects``, ``capped``) is not told from, and the key.

    Named, the tied hypothesis is not told from its rival's effect; the rival's effect named,
    from the tied hypothesis (its key, "a+b", is the second item). None when no tie doubts it.
    """
    if capped != NOT_TOLD_APART:
        return None
    key = "+".join(effects)
    if key in summary.not_told_from:
        return summary.not_told_from[key], key
    tied = [k for k, effect in summary.not_told_from.items() if effect == key]
    return (tied[0].replace("+", " and "), tied[0]) if tied else None


def _doubted(summary: Summary, verdict: Verdict) -> Verdict:
    """``verdict`` doubted in words (``NOT_TOLD_APART``), its margin at most 0."""
    margin = min(verdict.margin, 0.0)
    sure = reliability(traits(summary, verdict.effects, True, margin))
    return replace(verdict, confidence=sure, margin=margin, capped=NOT_TOLD_APART)
