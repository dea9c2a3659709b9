"""Family c's hose compliance: the hose as two segments, each a resistance and a node."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
import math
from typing import ClassVar

import numpy as np

from brake_hil.virtual_rig.effects.base import STRENGTH, Parameter
from brake_hil.virtual_rig.family_c.base import FamilyCEffect, register_effect_c
from brake_hil.virtual_rig.laws import LineFlow, LinePorts, LtiPlant, Signal, State, TruthLaw


@dataclass(frozen=True)
class _TwoSegmentHose(TruthLaw):
    wall_compliance: float  # m^3/Pa, the swelling wall of each half
    volume: float  # m^3, the fluid in each half

    def states(self) -> tuple[State, ...]:
        return (State("hose_mid_pressure", 1e6),)

    def initial_state(self, equilibrium: Mapping[str, float]) -> tuple[float, ...]:
        return (equilibrium["p_b"],)

    def line_flow(self, line: LinePorts, states: Sequence[Signal]) -> LineFlow:
        middle = states[0]
        half = 0.5 * line.hose_resistance
        rate = (
            line.master_pressure - middle - line.upstream_drop - half * line.flow
        ) / line.inertance
        into_bore = (middle - line.bore_pressure) / half
        node = self.wall_compliance + self.volume * line.compliance_at(middle)
        end = self.wall_compliance + self.volume * line.compliance_at(line.bore_pressure)
        return rate, [(line.flow - into_bore) / node], into_bore, end


@register_effect_c
@dataclass(frozen=True)
class HoseComplianceC(FamilyCEffect, effect="hose_compliance"):
    """The hose as a distributed line of two segments: resistance, node, resistance, node.

    The braided hose's swell (its volumetric expansion per metre and pascal, ``e_h``, an aged
    hose near the brake-hose standards' limit of about 0.66 cm^3 per foot at 1000 psi) and its
    own fluid's compliance are lumped at two nodes, half each: one in the hose's middle, one
    at its bore end (added to the bore chamber), each behind half the hose's laminar
    resistance ``R_t`` (seed eq. 13); eq. 21c lumps all of it into the bore's modulus.
    """

    expansion: float = 3.0e-13

    parameters: ClassVar[tuple[Parameter, ...]] = (
        STRENGTH,
        Parameter("expansion", "m^3/(Pa m)", 5e-14, 1e-12, "the hose's volumetric expansion e_h"),
    )
    diagnosis_model: ClassVar[str] = (
        "one RC stage of the hose's compliance; the truth has two segments, each behind R_t / 2"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> HoseComplianceC:
        """This law at ``strength``, its own parameters drawn from ``rng`` (a case's draw)."""
        return cls(strength=strength, expansion=float(np.round(rng.uniform(2e-13, 4e-13), 15)))

    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""
        hose = plant.rig.hose
        swell = self.strength * self.expansion * hose.length
        volume = math.pi / 4.0 * hose.diameter**2 * hose.length
        return _TwoSegmentHose(0.5 * swell, 0.5 * self.strength * volume)
