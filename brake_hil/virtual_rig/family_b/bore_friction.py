"""bore_friction, family b: a velocity-dependent (Stribeck) friction curve, no pre-sliding."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.family_b.base import FamilyBEffect, register_effect_b
from brake_hil.virtual_rig.laws import LtiPlant, Signal
from brake_hil.virtual_rig.mechanics import CockedContact

__all__ = ["BoreFrictionB", "StribeckBoreFriction"]


@dataclass(frozen=True)
class StribeckBoreFriction(CockedContact):
    """Piston-bore friction bound to a rig (SI): the host's bore-force port, no own states."""

    static_coefficient: float  # mu_S, -
    kinetic_ratio: float  # mu_C / mu_S, -
    stribeck_velocity: float  # v_S, m/s
    stribeck_exponent: float  # delta, -
    regularisation_velocity: float  # v_e, m/s
    viscous_coefficient: float  # mu_v, s/m, viscous friction per unit normal force
    guide_length: float  # l_g, m
    bore_area: float  # A_eb, m^2

    def coefficient(self, velocity: Signal) -> Signal:
        """``mu(v) tanh(v / v_e) + mu_v v`` (-), ``mu = mu_C + (mu_S - mu_C) exp(-|v/v_S|^d)``."""
        kinetic = self.kinetic_ratio * self.static_coefficient
        decay = fm.exp(-(fm.absolute(velocity / self.stribeck_velocity) ** self.stribeck_exponent))
        curve = kinetic + (self.static_coefficient - kinetic) * decay
        mu: Signal = curve * fm.tanh(velocity / self.regularisation_velocity) + (
            self.viscous_coefficient * velocity
        )
        return mu

    def bore_force(
        self,
        velocity: Signal,
        bore_pressure: Signal,
        caliper_displacement: Signal,
        states: Sequence[Signal],
    ) -> tuple[Signal, list[Signal]]:
        """Friction on the piston ``mu(v) N`` (N), opposing the seal velocity; no states."""
        del states
        force = self.coefficient(velocity) * self.normal_force(bore_pressure, caliper_displacement)
        return force, []


@register_effect_b
@dataclass(frozen=True)
class BoreFrictionB(FamilyBEffect, effect="bore_friction"):
    """Piston-bore friction from caliper cocking (family b): a static Stribeck curve.

    Under load the cut caliper tilts and the piston bears on its bore, so friction proportional
    to ``p_b |x_c|`` opposes the piston's slide (seed eqs. 8-9) and adds damping ``c_fb``. The
    simulator takes the contact force ``N = 4 A_eb p_b |x_c| / l_g`` over the piston's guide
    length and a velocity-dependent friction coefficient with no memory: the generalised
    Stribeck curve ``mu(v) = mu_C + (mu_S - mu_C) exp(-|v / v_S|^d)``, regularised at zero
    velocity by ``tanh(v / v_e)``, plus boundary-lubricated viscous friction ``mu_v v``, so
    ``F = N (mu(v) tanh(v / v_e) + mu_v v)`` (Andersson, Soderberg, Bjorklund, "Friction models
    for sliding dry, boundary and mixed lubricated contacts", Tribology International 40(4),
    2007), ``mu_S = strength mu_fb``. Unlike family a (Dahl's pre-sliding state with the
    Stribeck curve inside it) the contact has no elastic pre-sliding: below ``v_e`` it acts as a
    steep viscous damper, above as a falling then rising curve.
    Source: seed eqs. 8-9; Andersson et al. (2007).
    """

    strength: float = 1.0
    guide_length: float = 2.5e-3
    kinetic_ratio: float = 0.85
    stribeck_velocity: float = 2.0e-3
    stribeck_exponent: float = 1.0
    regularisation_velocity: float = 2.0e-4
    viscous_coefficient: float = 20.0

    parameters = (
        STRENGTH,
        Parameter("guide_length", "m", 1.0e-3, 0.05, "l_g, arm of the cocking couple"),
        Parameter("kinetic_ratio", "-", 0.3, 1.0, "mu_C / mu_S"),
        Parameter("stribeck_velocity", "m/s", 1.0e-5, 0.1, "v_S of the Stribeck curve"),
        Parameter("stribeck_exponent", "-", 0.5, 2.0, "d of the Stribeck curve"),
        Parameter("regularisation_velocity", "m/s", 1.0e-6, 1.0e-3, "v_e of tanh(v / v_e)"),
        Parameter("viscous_coefficient", "s/m", 0.0, 1000.0, "mu_v, viscous share per N"),
    )
    diagnosis_model = (
        "ideal Coulomb friction F = mu N sign(x_s') with N ~ p_b |x_c| (eqs. 8-9) or its "
        "equivalent viscous c_fb; the simulator's coefficient follows a generalised Stribeck "
        "curve with viscous friction and a regularised zero crossing"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> Effect:
        """Guide length 2-3 mm, ``mu_C / mu_S`` 0.75-0.95, ``v_S`` 1-5 mm/s.

        And ``d`` 0.6-1.5, ``v_e`` 0.1-0.3 mm/s; each uniformly, at ``strength``.
        """
        return cls(
            strength=strength,
            guide_length=float(np.round(rng.uniform(2.0e-3, 3.0e-3), 6)),
            kinetic_ratio=float(np.round(rng.uniform(0.75, 0.95), 3)),
            stribeck_velocity=float(np.round(rng.uniform(1.0e-3, 5.0e-3), 6)),
            stribeck_exponent=float(np.round(rng.uniform(0.6, 1.5), 3)),
            regularisation_velocity=float(np.round(rng.uniform(1.0e-4, 3.0e-4), 6)),
        )

    def law(self, plant: LtiPlant) -> StribeckBoreFriction:
        """The friction of the plant's truth bore at this strength."""
        return StribeckBoreFriction(
            static_coefficient=self.strength * plant.rig.bore_friction_coefficient,
            kinetic_ratio=self.kinetic_ratio,
            stribeck_velocity=self.stribeck_velocity,
            stribeck_exponent=self.stribeck_exponent,
            regularisation_velocity=self.regularisation_velocity,
            viscous_coefficient=self.viscous_coefficient,
            guide_length=self.guide_length,
            bore_area=plant.params.bore_area,
        )

    def install(self, plant: LtiPlant) -> StribeckBoreFriction | None:
        """Bore-force port: friction in parallel with the seals (none on a frictionless bore)."""
        if not self.active or plant.rig.bore_friction_coefficient == 0.0:
            return None
        return self.law(plant)
