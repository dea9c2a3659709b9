"""Family c's bore friction: the cocked caliper pinches the piston at its land, Coulomb sliding."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from brake_hil.virtual_rig.effects.base import STRENGTH, Parameter
from brake_hil.virtual_rig.family_c._common import smooth_abs, smooth_sign
from brake_hil.virtual_rig.family_c.base import FamilyCEffect, register_effect_c
from brake_hil.virtual_rig.laws import LtiPlant, Signal, TruthLaw

SCORING = 1.5
"""A scored bore's friction over the rig file's ``mu_fb``, at full strength."""


@dataclass(frozen=True)
class _PinchedPiston(TruthLaw):
    coefficient: float  # -, mu_fb at this strength
    lever: float  # m^2 / m: A_eb (2 L_b / L_e) / l_c, normal force per (p_b |x_c|)
    clearance: float  # m, x_c the radial clearance takes up before the piston bears
    velocity_width: float  # m/s, the rounding of the Coulomb switch

    def bore_force(
        self,
        velocity: Signal,
        bore_pressure: Signal,
        caliper_displacement: Signal,
        states: object,
    ) -> tuple[Signal, list[Signal]]:
        del states
        cocked = smooth_abs(caliper_displacement, self.clearance)
        normal = self.lever * bore_pressure * cocked
        return self.coefficient * normal * smooth_sign(velocity, self.velocity_width), []


@register_effect_c
@dataclass(frozen=True)
class BoreFrictionC(FamilyCEffect, effect="bore_friction"):
    """Bore friction from cocking: the pressure's moment pinches the piston at its land.

    The caliper turns by ``x_c / l_c``; the pressure force ``A_eb p_b``, now off the bore's
    axis by that angle times the lever ``L_b``, makes a moment that the piston's short guiding
    land ``L_e`` takes as two opposite contact forces, so the normal force is
    ``2 (L_b / L_e) A_eb p_b |x_c| / l_c`` once the radial clearance is taken up (seed eq. 8
    writes 4 for the lever ratio); sliding against it is Coulomb friction ``mu_fb`` (the rig
    file's, up to 1.5 times it in a scored bore), rounded at slip velocities below a tenth
    of a mm/s.
    """

    lever_ratio: float = 70.0

    parameters: ClassVar[tuple[Parameter, ...]] = (
        STRENGTH,
        Parameter("lever_ratio", "-", 4.0, 150.0, "2 L_b / L_e: pressure lever over land"),
    )
    diagnosis_model: ClassVar[str] = (
        "Coulomb friction ~ p_b |x_c|; the truth takes up a clearance first and has its own lever"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> BoreFrictionC:
        """This law at ``strength``, its own parameters drawn from ``rng`` (a case's draw)."""
        return cls(strength=strength, lever_ratio=float(np.round(rng.uniform(50.0, 90.0), 2)))

    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""
        rig = plant.rig
        lever = self.lever_ratio * plant.params.bore_area / rig.transducer_distance
        return _PinchedPiston(
            SCORING * self.strength * rig.bore_friction_coefficient, lever, 5.0e-6, 1.0e-4
        )
