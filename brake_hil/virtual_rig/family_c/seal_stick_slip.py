"""Family c's seal stick-slip: a Maxwell-slip (Iwan) seal of elasto-viscoplastic elements."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from brake_hil.physics.parameters import seal_properties
from brake_hil.virtual_rig.effects.base import STRENGTH, Parameter
from brake_hil.virtual_rig.family_c._common import positive_part
from brake_hil.virtual_rig.family_c.base import FamilyCEffect, register_effect_c
from brake_hil.virtual_rig.laws import LtiPlant, SealPorts, Signal, State, TruthLaw

ELEMENTS = 4
"""Elements of the seal's contact, from the groove's corner to its lip."""


@dataclass(frozen=True)
class _MaxwellSlipSeal(TruthLaw):
    stiffness: tuple[float, ...]  # N/m, each element's shear stiffness (both seals)
    threshold: tuple[float, ...]  # N, each element's slip force (both seals)
    mobility: float  # m/(N s): slip velocity per newton above the threshold
    share: float  # -, share of the seal force the elements carry
    width: float  # N, rounding of the threshold

    def states(self) -> tuple[State, ...]:
        return tuple(State(f"seal_element_force_{i}", 10.0) for i in range(ELEMENTS))

    def initial_state(self, equilibrium: Mapping[str, float]) -> tuple[float, ...]:
        x = equilibrium["seal_displacement"]
        return tuple(float(np.clip(k * x, -f, f)) for k, f in zip(self.stiffness, self.threshold))

    def seal_force(self, seal: SealPorts, states: Sequence[Signal]) -> tuple[Signal, list[Signal]]:
        rates: list[Signal] = []
        total: Signal = 0.0 * seal.velocity
        grip = seal.modulus_factor
        for k, limit, force in zip(self.stiffness, self.threshold, states):
            apply_limit = limit * (1.0 - seal.asymmetry) * grip
            release_limit = limit * (1.0 + seal.asymmetry) * grip
            over = positive_part(force - apply_limit, self.width) - positive_part(
                -force - release_limit, self.width
            )
            slip = self.mobility * over  # m/s, the element's contact sliding
            rates.append(k * grip * (seal.velocity - slip))
            total = total + force
        return (1.0 - self.share) * seal.spring_force + self.share * total, rates

    def spring_share(self) -> float:
        return 1.0 - self.share


@register_effect_c
@dataclass(frozen=True)
class SealStickSlipC(FamilyCEffect, effect="seal_stick_slip"):
    """Seal stick-slip as a Maxwell-slip (Iwan) model: elements that stick, then creep.

    Each seal's contact with the piston is split into elements from the groove's corner to the
    lip (seed eqs. 2-3: together the static stiffness ``k_s`` and the friction threshold
    ``F_fs``, the thresholds spread so the contact lets go gradually); each element is a shear
    spring in series with a Bingham slider, which sticks below its threshold and slides at a
    velocity proportional to the excess force above it (a viscoplastic contact, Iwan 1966;
    Al-Bender et al. 2004). The elements carry the share ``phi`` of the seal force, the
    equivalent ``k_eh``, ``c_eh`` the rest. Honours the host's seal asymmetry port.
    """

    spread: float = 0.6
    relaxation_time: float = 3.0e-4

    parameters: ClassVar[tuple[Parameter, ...]] = (
        STRENGTH,
        Parameter("spread", "-", 0.0, 0.9, "spread of the element thresholds about F_fs / N"),
        Parameter(
            "relaxation_time", "s", 5.0e-5, 2.0e-3, "an element's slip time constant, 1/(k mu)"
        ),
    )
    diagnosis_model: ClassVar[str] = (
        "a Coulomb seal of two-valued stiffness; the truth spreads the threshold over four "
        "elements that slide viscoplastically"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> SealStickSlipC:
        """This law at ``strength``, its own parameters drawn from ``rng`` (a case's draw)."""
        return cls(
            strength=strength,
            spread=float(np.round(rng.uniform(0.3, 0.8), 3)),
            relaxation_time=float(np.round(rng.uniform(1.5e-4, 6.0e-4), 6)),
        )

    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""
        seal = seal_properties(plant.rig)
        weights = 1.0 + self.spread * np.linspace(-1.0, 1.0, ELEMENTS)
        threshold = tuple(float(2.0 * seal.friction_threshold * w / ELEMENTS) for w in weights)
        k = 2.0 * seal.static_stiffness / ELEMENTS
        return _MaxwellSlipSeal(
            stiffness=(k,) * ELEMENTS,
            threshold=threshold,
            mobility=1.0 / (k * self.relaxation_time),
            share=0.25 * self.strength,
            width=0.01 * min(threshold),
        )
