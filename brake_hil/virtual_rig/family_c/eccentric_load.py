"""Family c's eccentric load: a centre of force that walks outward as the block is loaded."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from brake_hil.virtual_rig.effects.base import STRENGTH, Parameter
from brake_hil.virtual_rig.family_c.base import FamilyCEffect, register_effect_c
from brake_hil.virtual_rig.laws import LtiPlant, Signal, TruthLaw


@dataclass(frozen=True)
class _WalkingCentre(TruthLaw):
    offset: float  # -, e_max / b_c: the centre's farthest offset over the caliper's arm
    half_load: float  # N, the pressure force at which the centre has walked half way

    def caliper_share(self, pressure_force: Signal) -> Signal:
        load = abs(pressure_force) if isinstance(pressure_force, float) else np.abs(pressure_force)
        return 1.0 - self.offset * load / (load + self.half_load)


@register_effect_c
@dataclass(frozen=True)
class EccentricLoadC(FamilyCEffect, effect="eccentric_load"):
    """Eccentric load through a moment arm that grows with load (the seed's eq. 22).

    The block's centre of force sits off the pistons' axis by ``e``; the moment ``e F`` is
    taken by the support columns, so the caliper body sees ``(1 - e / b_c) A_eb p_b``. As the
    load grows the pads' (here the block's) contact spreads toward the stiffer side and the
    centre walks outward, ``e = e_max F / (F + F_half)``: the share falls with load and
    saturates. More washers raise the caliper off the columns and lengthen the arm.
    """

    half_load: float = 3.0e3

    parameters: ClassVar[tuple[Parameter, ...]] = (
        STRENGTH,
        Parameter("half_load", "N", 5.0e2, 2.0e4, "pressure force at half the centre's walk"),
    )
    diagnosis_model: ClassVar[str] = (
        "a share s0 + s1 p_b of the pressure force; the truth's share saturates with load"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> EccentricLoadC:
        """This law at ``strength``, its own parameters drawn from ``rng`` (a case's draw)."""
        return cls(strength=strength, half_load=float(np.round(rng.uniform(1.5e3, 6.0e3), 1)))

    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""
        washers = 1.0 + 0.1 * (plant.rig.washers - 1)
        return _WalkingCentre(0.08 * self.strength * washers, self.half_load)
