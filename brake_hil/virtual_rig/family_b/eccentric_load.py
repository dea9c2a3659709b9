"""eccentric_load, family b: the washer stack compresses and moves the support's reaction."""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.family_b.base import FamilyBEffect, register_effect_b
from brake_hil.virtual_rig.laws import LtiPlant, Signal, TruthLaw

__all__ = ["CompressingStackShare", "EccentricLoadB"]


def _softplus(value: Signal) -> Signal:
    """``ln(1 + e^value)``, computed without overflow."""
    if isinstance(value, float):
        return max(value, 0.0) + math.log1p(math.exp(-abs(value)))
    return np.logaddexp(0.0, value)


@dataclass(frozen=True)
class CompressingStackShare(TruthLaw):
    """Share of ``A_eb p_b`` that reaches the caliper, as a function of that force.

    The host's caliper-share port.
    """

    unloaded_change: float  # d_0, -, share - 1 at zero force
    solid_change: float  # d_1, -, share - 1 once the stack is solid
    solid_force: float  # F_s, N, force at which the stack goes solid
    knee_width: float  # W, N, width of the smooth knee at F_s

    def caliper_share(self, pressure_force: Signal) -> Signal:
        """``1 + d_1 + (d_0 - d_1) W softplus((F_s - F) / W) / F_s`` (-), ``F = A_eb p_b`` (N).

        The share moves linearly with the force from ``1 + d_0`` and stops at ``1 + d_1``.
        """
        ramp = self.knee_width * _softplus((self.solid_force - pressure_force) / self.knee_width)
        share: Signal = (
            1.0
            + self.solid_change
            + (self.unloaded_change - self.solid_change) * ramp / self.solid_force
        )
        return share


@register_effect_b
@dataclass(frozen=True)
class EccentricLoadB(FamilyBEffect, effect="eccentric_load"):
    """Eccentric loading of the cut caliper (family b): a washer stack compressing to solid.

    With washers under the mounting, the caliper's pressure force and the support reaction act
    on different lines, and the moment balance of seed eqs. 22a-c (moment arms ``b_k``, ``b_b``,
    ``b_p``, ``d_b``, ``b_c``, the washer stack ``(a - 1) w_w``) gives the caliper a different
    share of the pressure force than ``A_eb p_b``. The simulator lets the stack compress
    elastically under the clamp load, so the reaction's arm, and with it the share, moves
    linearly with the force until the stack is solid at ``F_s`` and stays there:
    ``F_c = A_eb p_b (1 + d_1 + (d_0 - d_1) r(F))`` with the ramp ``r = max(1 - F / F_s, 0)``
    rounded over a knee of width ``W`` (a softplus); ``d_0`` unloaded and ``d_1`` solid, scaled
    by ``strength`` (bolted-joint member stiffness: VDI 2230 Part 1, 2015). Only the caliper's
    equation (21f) changes. Unlike family a (a hyperbolic seating ``F_0 / (F_0 + F)`` that never
    ends) the share stops changing at a finite force, with a knee.
    Source: seed eq. 22 and Table 5; VDI 2230 (2015).
    """

    strength: float = 1.0
    unloaded_share_change: float = -0.35
    solid_share_change: float = -0.05
    solid_force: float = 6000.0
    knee_share: float = 0.15

    parameters = (
        STRENGTH,
        Parameter("unloaded_share_change", "-", -0.6, 0.6, "d_0 at strength 1 (share - 1)"),
        Parameter("solid_share_change", "-", -0.6, 0.6, "d_1 at strength 1 (share - 1)"),
        Parameter("solid_force", "N", 100.0, 1.0e5, "F_s, the stack goes solid"),
        Parameter("knee_share", "-", 0.01, 0.5, "W / F_s, the knee's width"),
    )
    diagnosis_model = (
        "a caliper force share (A_eb replaced by s A_eb, eq. 22c) quadratic in p_b about "
        "1 MPa; the simulator's share falls linearly with the force and stops at the stack's "
        "solid force, a knee no polynomial has"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> Effect:
        """``d_0`` -0.45 to -0.25, ``d_1`` -0.1 to 0, solid force 4-9 kN, knee 0.1-0.25."""
        return cls(
            strength=strength,
            unloaded_share_change=float(np.round(rng.uniform(-0.45, -0.25), 3)),
            solid_share_change=float(np.round(rng.uniform(-0.1, 0.0), 3)),
            solid_force=float(np.round(rng.uniform(4000.0, 9000.0), 0)),
            knee_share=float(np.round(rng.uniform(0.1, 0.25), 3)),
        )

    def law(self, plant: LtiPlant) -> CompressingStackShare:
        """The stack's law at this strength (caliper-share port; the same on every rig)."""
        del plant
        return CompressingStackShare(
            unloaded_change=self.strength * self.unloaded_share_change,
            solid_change=self.strength * self.solid_share_change,
            solid_force=self.solid_force,
            knee_width=self.knee_share * self.solid_force,
        )
