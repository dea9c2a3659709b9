"""seal_groove_asymmetry, family b: a seal stiffness graded across the groove's clearance."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.family_b.base import FamilyBEffect, register_effect_b
from brake_hil.virtual_rig.laws import LtiPlant, Signal
from brake_hil.virtual_rig.mechanics import RelaxingGroove

__all__ = ["GradedGroove", "SealGrooveAsymmetryB"]


@dataclass(frozen=True)
class GradedGroove(RelaxingGroove):
    """The groove's graded stiffness bound to a strength (SI).

    The host's spring-deflection port (state ``x_r``, where the seal sits in its groove) and the
    seal's apply/release asymmetry.
    """

    asymmetry: float  # a, -
    clearance: float  # delta, m, half the seal's travel in the groove before it is dragged
    creep_time: float  # tau, s, Norton creep time at e = delta
    creep_exponent: float  # p, -, Norton exponent

    def groove_deflection(self, deflection: Signal) -> Signal:
        """``e (1 - a e / (2 delta))`` (m) at ``e = x_s - x_r``.

        The stiffness ``1 - a e / delta`` falls across the clearance toward the apply side and
        rises toward the release side.
        """
        ratio = deflection / self.clearance
        shifted: Signal = deflection * (1.0 - 0.5 * self.asymmetry * ratio)
        return shifted

    def relaxation_rate(self, deflection: Signal) -> Signal:
        """``x_r' = (delta / tau) sign(e) |e / delta|^p`` (m/s), Norton's law.

        It drags the seal along once ``|e|`` nears ``delta`` and barely moves it inside.
        """
        ratio = deflection / self.clearance
        creep: Signal = (
            self.clearance
            / self.creep_time
            * ratio
            * fm.absolute(ratio) ** (self.creep_exponent - 1.0)
        )
        return creep


@register_effect_b
@dataclass(frozen=True)
class SealGrooveAsymmetryB(FamilyBEffect, effect="seal_groove_asymmetry"):
    """Seal-groove asymmetry (family b): the seal's stiffness graded across its groove clearance.

    The groove's chamfer on the pressure side gives the rectangular seal room to lean out as the
    piston applies and backs it on its square wall as the piston returns (Anwana, Cai, Chang,
    "Analysis of brake caliper seal-groove design", SAE 2002-01-0927). The simulator lets the
    seal travel ``e`` within a clearance of about ``+-delta`` about where it sits in the groove,
    ``x_r``, with a stiffness falling linearly across it, ``k_eh (1 - a e / delta)`` (soft toward
    the chamfer, stiff toward the wall), i.e. ``F = k_eh (x_r + e - a e^2 / (2 delta))``, a
    smooth quadratic spring rather than two stiffnesses; the seal is dragged to a new seat by a
    Norton power-law creep ``x_r' = (delta / tau) sign(e) |e / delta|^p`` (Norton, The creep of
    steel at high temperatures, McGraw-Hill 1929), nearly rate-independent like a play operator
    (Krasnosel'skii, Pokrovskii, Systems with Hysteresis, Springer 1989). Unlike family a (a
    tanh switch between ``(1 - a)`` and ``(1 + a)`` about a linearly creeping position) the
    stiffness varies continuously and the memory is a clearance. A frictional seal
    (seal_stick_slip) yields at ``(1 - a)`` of its threshold on apply and ``(1 + a)`` on release.
    Source: the seed's list of physics its LTI model leaves out; Anwana et al. (2002).
    """

    strength: float = 1.0
    asymmetry: float = 0.8
    clearance: float = 3.0e-5
    creep_time: float = 0.2
    creep_exponent: float = 5.0

    parameters = (
        STRENGTH,
        Parameter("asymmetry", "-", 0.05, 0.95, "a at strength 1: stiffness 1 -+ a at +-delta"),
        Parameter("clearance", "m", 1.0e-6, 1.0e-4, "delta, the seal's travel in its groove"),
        Parameter("creep_time", "s", 1.0e-4, 1.0, "tau of the Norton creep at e = delta"),
        Parameter("creep_exponent", "-", 1.0, 9.0, "p of the Norton creep"),
    )
    diagnosis_model = (
        "a bilinear seal stiffness (k_apply, k_release) switching on the sign of the seal "
        "velocity, or a Jenkins slider with two thresholds; the simulator's stiffness is "
        "graded across a clearance the seal is dragged through by power-law creep"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> Effect:
        """Asymmetry 0.65-0.9, clearance 20-40 um, creep time 0.1-0.5 s, exponent 4-7."""
        return cls(
            strength=strength,
            asymmetry=float(np.round(rng.uniform(0.65, 0.9), 3)),
            clearance=float(np.round(rng.uniform(2.0e-5, 4.0e-5), 7)),
            creep_time=float(np.round(rng.uniform(0.1, 0.5), 3)),
            creep_exponent=float(np.round(rng.uniform(4.0, 7.0), 3)),
        )

    def law(self, plant: LtiPlant) -> GradedGroove:
        """The graded groove at asymmetry ``strength * asymmetry`` (the same on every rig)."""
        del plant
        return GradedGroove(
            asymmetry=self.strength * self.asymmetry,
            clearance=self.clearance,
            creep_time=self.creep_time,
            creep_exponent=self.creep_exponent,
        )
