"""Family c's seal groove asymmetry: a bilinear seal spring about a creeping rest position."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from brake_hil.virtual_rig.effects.base import STRENGTH, Parameter
from brake_hil.virtual_rig.family_c._common import smooth_abs
from brake_hil.virtual_rig.family_c.base import FamilyCEffect, register_effect_c
from brake_hil.virtual_rig.laws import LtiPlant, Signal, State, TruthLaw


@dataclass(frozen=True)
class _BilinearGroove(TruthLaw):
    asymmetry: float  # -, a: slope (1 - a) outward of the rest position, (1 + a) inward
    creep_time: float  # s, the rest position's creep toward the seal displacement
    width: float  # m, rounding of the corner at the rest position

    def states(self) -> tuple[State, ...]:
        return (State("seal_rest_position", 1e-5),)

    def initial_state(self, equilibrium: Mapping[str, float]) -> tuple[float, ...]:
        return (equilibrium["seal_displacement"],)

    def spring_deflection(
        self, seal_displacement: Signal, states: Sequence[Signal]
    ) -> tuple[Signal, list[Signal]]:
        rest = states[0]
        away = seal_displacement - rest
        deflection = seal_displacement - self.asymmetry * smooth_abs(away, self.width)
        return deflection, [away / self.creep_time]


@register_effect_c
@dataclass(frozen=True)
class SealGrooveAsymmetryC(FamilyCEffect, effect="seal_groove_asymmetry"):
    """Groove asymmetry as a bilinear seal spring about a rest position that creeps.

    The groove's chamfer on the pressure side lets the seal lean outward (toward the block)
    with the slope ``(1 - a) k_eh`` and rolls it back inward with ``(1 + a) k_eh`` (the seed's
    'typical asymmetry of the seal groove designs', section on ``k_eh``); the corner between
    the two sits at the seal's rest position, which creeps toward the seal displacement with
    the elastomer's time ``tau_r``, so under pulsing it sits near the mean and the apply and
    release halves of each cycle see different stiffnesses (even harmonics, a shifted mean).
    """

    creep_time: float = 0.4

    parameters: ClassVar[tuple[Parameter, ...]] = (
        STRENGTH,
        Parameter("creep_time", "s", 0.05, 5.0, "creep time tau_r of the seal's rest position"),
    )
    diagnosis_model: ClassVar[str] = (
        "an apply/release stiffness asymmetry a; the truth bends at a rest position that creeps"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> SealGrooveAsymmetryC:
        """This law at ``strength``, its own parameters drawn from ``rng`` (a case's draw)."""
        return cls(strength=strength, creep_time=float(np.round(rng.uniform(0.2, 1.5), 3)))

    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""
        del plant
        return _BilinearGroove(0.5 * self.strength, self.creep_time, 2.0e-7)
