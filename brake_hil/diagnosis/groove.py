"""Is the seal's apply/release asymmetry (the groove's) resolved by the recording?

Plain stick-slip (``seal_stick_slip``) and the groove asymmetry (``seal_groove_asymmetry``)
are one seal law apart: the groove candidate is the stick-slip seal (and the equivalent
spring) with its stiffness ``(1 - a)`` on the loop's apply edges and ``(1 + a)`` on its
release edges. Its fitted ``a``, with the fit's one-sigma uncertainty, measures how much the
loop's apply and release edges differ: the release/apply stiffness ratio
``(1 + a) / (1 - a)`` and its interval of ``ASYMMETRY_SIGMAS`` sigmas. Three answers:

* **asymmetric**: the interval excludes 1 (the edges differ), or the groove leaves less than
  ``1 / CUT_RATIO`` of the held-out error the best symmetric seal leaves (plain stick-slip or
  the calibrated LTI seal; a groove's bilinear spring beside an unidentified frictional share
  widens the interval of ``a`` while its fit is plain): the groove may be named, when
  its held-out fit also beats stick-slip's by more than its extra parameters cost (the
  verdict's score); the physics check :func:`asymmetry_check` sets aside a groove whose
  asymmetry is not resolved;
* **symmetric**: the interval lies within ``1 +- SYMMETRIC_RATIO``: resolved too, the seal is
  symmetric as plain stick-slip has it;
* **not resolved**: neither: "stick-slip; groove asymmetry not resolved".
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from brake_hil.diagnosis.fitting import Fit

__all__ = [
    "ASYMMETRY_SIGMAS",
    "CUT_RATIO",
    "GROOVE",
    "STICK_SLIP",
    "SYMMETRIC_RATIO",
    "GrooveAsymmetry",
    "groove_asymmetry",
    "seal_asymmetry",
    "symmetric_seals",
]

GROOVE = "seal_groove_asymmetry"
STICK_SLIP = "seal_stick_slip"
ASYMMETRY_SIGMAS = 2.0
"""Half-width of the ratio's interval in the fit's sigmas (about 95 % for a Gaussian)."""
A_LIMIT = 0.999
"""The largest asymmetry ``|a|`` an interval reaches: at it the recording does not bound the
ratio (a release/apply stiffness ratio of 1999 or 1/1999), and the words say so."""
SYMMETRIC_RATIO = 0.1
"""A release/apply stiffness ratio within ``1 +- 0.1`` is a symmetric seal: the smallest
groove asymmetry the catalogue's range describes (``a`` = 0.05, the virtual rig's lower bound)
makes a ratio of 1.105."""
CUT_RATIO = 2.0
"""A groove that leaves half the held-out error of the best symmetric seal or less is
asymmetric whatever its interval: the verdict's own bar for a physics (``ACCEPT_RATIO``)."""
_PARAMETER = "stiffness_asymmetry"


@dataclass(frozen=True)
class GrooveAsymmetry:
    """The groove's fitted apply/release asymmetry and what it resolves."""

    asymmetry: float  # a, -
    sigma: float  # one sigma of a, - (inf when the fit gives none)
    ratio: float  # release / apply stiffness, (1 + a) / (1 - a)
    interval: tuple[float, float]  # the ratio's ASYMMETRY_SIGMAS interval
    cut: float = 1.0  # held-out error of the best symmetric seal over the groove's

    @property
    def asymmetric(self) -> bool:
        """The interval excludes a symmetric seal (ratio 1), or the groove fits far better."""
        return self.interval[0] > 1.0 or self.interval[1] < 1.0 or self.cut >= CUT_RATIO

    @property
    def symmetric(self) -> bool:
        """The interval lies within ``1 +- SYMMETRIC_RATIO``."""
        if self.asymmetric:
            return False
        low, high = self.interval
        return low >= 1.0 - SYMMETRIC_RATIO and high <= 1.0 + SYMMETRIC_RATIO

    @property
    def resolved(self) -> bool:
        """Either answer is resolved: asymmetric, or symmetric."""
        return self.asymmetric or self.symmetric

    def in_words(self) -> str:
        """The ratio and its interval."""
        low, high = self.interval
        bounded = _ratio(-A_LIMIT) < low and high < _ratio(A_LIMIT)
        interval = f"interval {low:.2f}-{high:.2f}" if bounded else "interval not bounded"
        return (
            f"release/apply seal stiffness {self.ratio:.2f} "
            f"({interval}, {ASYMMETRY_SIGMAS:g} sigma); the groove "
            f"leaves {1 / self.cut:.2f} of the best symmetric seal's held-out error"
        )

    def verdict_words(self, effects: Sequence[str]) -> str:
        """What the verdict says of the groove: named, or stick-slip with or without it."""
        if GROOVE in effects:
            return f"groove asymmetry resolved: {self.in_words()}."
        if self.symmetric:
            return f"stick-slip; a symmetric seal, no groove asymmetry: {self.in_words()}."
        if self.asymmetric:
            return (
                f"stick-slip; an apply/release asymmetry is resolved ({self.in_words()}), "
                "but the groove model does not fit the held-out cycles better than its extra "
                "parameters cost."
            )
        return f"stick-slip; groove asymmetry not resolved: {self.in_words()}."

    def as_dict(self, effects: Sequence[str]) -> dict[str, object]:
        """``verdict.groove_asymmetry`` of diagnosis.json."""
        state = "asymmetric" if self.asymmetric else "symmetric" if self.symmetric else None
        return {
            "resolved": self.resolved,
            "named": GROOVE in effects,
            "answer": state or "not resolved",
            "apply_release_ratio": round(self.ratio, 4),
            "interval": [round(v, 4) for v in self.interval],
            "stiffness_asymmetry": round(self.asymmetry, 4),
            "sigma": round(self.sigma, 4),
            "cut_over_symmetric": round(self.cut, 3),
        }


def seal_asymmetry(fit: Fit, symmetric: Sequence[Fit] = ()) -> GrooveAsymmetry | None:
    """The groove's asymmetry as ``fit`` (a hypothesis with the groove) fitted it.

    ``symmetric``: the symmetric seals it is held against (the calibrated baseline, the
    stick-slip single); none: only the interval resolves it.
    """
    if GROOVE not in fit.effects:
        return None
    names = list(fit.parameter_names)
    index = names.index(_PARAMETER)
    a = float(fit.theta[index])
    sigma = float("inf") if fit.uncertainty is None else float(fit.uncertainty[index])
    if not sigma == sigma:  # NaN
        sigma = float("inf")
    low = max(a - ASYMMETRY_SIGMAS * sigma, -A_LIMIT)
    high = min(a + ASYMMETRY_SIGMAS * sigma, A_LIMIT)
    best = min((h.held_out_cost for h in symmetric), default=fit.held_out_cost)
    cut = best / max(fit.held_out_cost, 1e-300)
    return GrooveAsymmetry(a, sigma, _ratio(a), (_ratio(low), _ratio(high)), cut)


def symmetric_seals(
    baseline: Fit,
    singles: Sequence[Fit],
    hypotheses: Sequence[Fit] = (),
    effects: Sequence[str] = (),
) -> list[Fit]:
    """The symmetric seals a groove is held against.

    The baseline and stick-slip's single, and, for a hypothesis of the groove with other
    ``effects``, the same with plain stick-slip in the groove's place when it was fitted (a
    symmetric seal in the same company).
    """
    twin = {STICK_SLIP if e == GROOVE else e for e in effects}
    same_company = [h for h in hypotheses if GROOVE in effects and set(h.effects) == twin]
    return [baseline, *(h for h in singles if h.effects == (STICK_SLIP,)), *same_company]


def groove_asymmetry(
    effects: Sequence[str], baseline: Fit, singles: Sequence[Fit]
) -> GrooveAsymmetry | None:
    """The groove single's asymmetry, for a verdict of stick-slip or the groove; else None."""
    if STICK_SLIP not in effects and GROOVE not in effects:
        return None
    groove = next((h for h in singles if h.effects == (GROOVE,)), None)
    if groove is None:
        return None
    return seal_asymmetry(groove, symmetric_seals(baseline, singles))


def _ratio(a: float) -> float:
    """Release over apply stiffness, ``(1 + a) / (1 - a)``."""
    return (1.0 + a) / (1.0 - a)
