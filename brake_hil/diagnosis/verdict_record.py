"""The verdict as decided: its effects, its confidence and a rule's doubt in words.

The record :func:`.verdict.decide` returns, and the words of each doubt (the caps: a rule that
doubts a verdict says so beside its number, and its confidence counts it, ``reliability.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
import math

__all__ = [
    "AS_RIG_VALUE",
    "CAME_CLOSE",
    "MAY_HIDE",
    "NOT_ALONE",
    "NOT_TOLD_APART",
    "OFF_PULSING",
    "SET_ASIDE",
    "Verdict",
    "confidence_text",
]

NOT_TOLD_APART = "not told apart from another effect by this recording"
"""The words of a verdict a tie doubts (``ties.py``; the explanation names the other effect)."""
NOT_ALONE = "not sure it is alone"
"""The words of a confidence capped because the single named may not be alone."""
SET_ASIDE = "a better fit failed a physics check"
"""The words of a confidence capped because a better-scoring hypothesis was set aside."""
CAME_CLOSE = "a library effect came close: it passed every rule but the generic forms' bar"
"""The words of an ``unexplained`` capped because a library effect missed only that bar."""
OFF_PULSING = "the confidence is fitted on steady pulsing, not on this recording's excitation"
"""The words of a verdict on a recording that is not steady pulsing alone (a sweep, a ramp, a
procedure): the confidence's benchmark sets were steady pulsing (:mod:`.reliability`), so it
is said as a doubted verdict's; on eight procedures of family a, 2 verdicts were right."""
MAY_HIDE = "the LTI model leaves more than the noise, unshaped, and a weaker effect may hide in it"
"""The words of a none reached above the noise floor (``NOISE_EXCESS``): what the model leaves
has no shape any candidate or generic form explains, so nothing is named, but the posterior's
share of none weighs only the hypotheses fitted, and an effect weaker than the leftover (a
weak hose beside a transducer's drifting zero) would not show."""
AS_RIG_VALUE = "its physics carried by the fitted model as a rig value outside its tolerance"
"""Words of an effect named as its own rig value a model carries far off: a doubted verdict."""


@dataclass(frozen=True)
class Verdict:
    """The decision: effects named, its confidence, and which hypothesis models them."""

    effects: tuple[str, ...]  # () none, ("unexplained",), or candidate names
    confidence: float
    chosen: tuple[str, ...] | None  # effects of the hypothesis kept as improved model
    margin: float = math.inf  # the smallest decision margin of the rules (log units)
    # Why a rule doubts the verdict, in words (its confidence counts it: reliability.py);
    # None when no rule does
    capped: str | None = None

    @property
    def by_rig_value(self) -> bool:
        """Named as its own rig value a model carries far off (``AS_RIG_VALUE``)."""
        return self.capped == AS_RIG_VALUE

    def confidence_text(self) -> str:
        """The confidence as printed: its number, and a rule's doubt in words."""
        return confidence_text(self.confidence, self.capped)


def confidence_text(confidence: float, capped: str | None) -> str:
    """``0.83``, or ``0.41, not sure it is alone`` when a rule doubts the verdict."""
    return f"{confidence:.2f}" if capped is None else f"{confidence:.2f}, {capped}"
