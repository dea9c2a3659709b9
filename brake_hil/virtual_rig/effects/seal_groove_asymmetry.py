"""seal_groove_asymmetry: the seal behaves differently on apply and on release."""

from __future__ import annotations

from dataclasses import dataclass

from brake_hil.physics import catalogue
from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.effects.registry import register_effect
from brake_hil.virtual_rig.laws import LtiPlant, Signal
from brake_hil.virtual_rig.mechanics import RelaxingGroove

SWITCH_WIDTH = 1.0e-6
"""Width (m) of the spring's smooth switch between its apply and release stiffness."""


def asymmetric_spring(deflection: Signal, asymmetry: float, width: float) -> Signal:
    """Effective deflection (m) of an asymmetric spring: ``e - a e tanh(e / w)``.

    The spring is ``(1 - a)`` as stiff on the apply side (``e > 0``) as on average and ``(1 + a)``
    on the release side.
    """
    effective: Signal = deflection - asymmetry * deflection * fm.tanh(deflection / width)
    return effective


@dataclass(frozen=True)
class GrooveAsymmetry(RelaxingGroove):
    """The groove's asymmetry bound to a strength.

    The host's spring-deflection port (state ``x_r``, the seal's relaxed position) and the seal's
    apply/release asymmetry.
    """

    asymmetry: float  # a, -
    relaxation_time: float  # tau_r, s
    width: float = SWITCH_WIDTH  # w, m

    def groove_deflection(self, deflection: Signal) -> Signal:
        """``e - a e tanh(e / w)`` (m) at ``e = x_s - x_r``."""
        return asymmetric_spring(deflection, self.asymmetry, self.width)

    def relaxation_rate(self, deflection: Signal) -> Signal:
        """``x_r' = e / tau_r`` (m/s)."""
        rate: Signal = deflection / self.relaxation_time
        return rate


@register_effect
@dataclass(frozen=True)
class SealGrooveAsymmetry(Effect):
    """Seal-groove asymmetry: the seal's stiffness and slip threshold differ on apply and release.

    The groove's chamfer on the pressure side lets the rectangular seal shear easily as the piston
    moves out (apply) and makes it push back harder as the piston returns (release, the seal's
    "rollback"), so the seal's stiffness and its slip threshold differ between the two directions
    (Anwana, Cai, Chang, "Analysis of brake caliper seal-groove design", SAE 2002-01-0927). On the
    equivalent spring ``k_eh`` the simulator measures the seal's deflection ``e`` from its slowly
    creeping relaxed position ``x_r`` (``x_r' = e / tau_r``) and gives it stiffness
    ``(1 - a) k_eh`` on the apply side and ``(1 + a) k_eh`` on the release side, smoothly:
    ``F = k_eh (x_r + e - a e tanh(e / w))``; on a frictional seal (seal_stick_slip) the slip
    threshold is ``(1 - a) g(v)`` on apply and ``(1 + a) g(v)`` on release.
    Source: the seed's list of physics its LTI model leaves out; Anwana et al. (2002).
    """

    strength: float = 1.0
    asymmetry: float = 0.4
    relaxation_time: float = 1.0

    entry = catalogue.entry("seal_groove_asymmetry")
    parameters = (
        STRENGTH,
        Parameter("asymmetry", "-", 0.05, 0.8, "a at strength 1: apply (1 - a), release (1 + a)"),
        Parameter("relaxation_time", "s", 0.05, 20.0, "tau_r, creep of the relaxed position"),
    )
    diagnosis_model = (
        "a bilinear seal stiffness (k_apply, k_release) switching on the sign of the seal "
        "velocity, or a Jenkins slider with two thresholds; the simulator switches smoothly "
        "about a creeping relaxed position, not on the velocity"
    )

    def law(self, plant: LtiPlant) -> GrooveAsymmetry:
        """Asymmetry ``strength * asymmetry`` with its relaxation time (the same on every rig)."""
        del plant
        return GrooveAsymmetry(self.strength * self.asymmetry, self.relaxation_time)
