"""Family c's orifice flow: a two-term (laminar plus turbulent) drop across the needle valve."""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import ClassVar

import numpy as np

from brake_hil.virtual_rig.effects.base import STRENGTH, Parameter
from brake_hil.virtual_rig.family_c._common import reference_flow
from brake_hil.virtual_rig.family_c.base import FamilyCEffect, register_effect_c
from brake_hil.virtual_rig.laws import LtiPlant, Signal, TruthLaw


@dataclass(frozen=True)
class _TwoTermOrifice(TruthLaw):
    laminar: float  # Pa s/m^3, the gap's viscous resistance at the rig file's viscosity
    turbulent: float  # Pa s^2/m^6, K of K Q |Q|: rho / (2 C_d^2 A^2)

    def valve_drop(
        self,
        flow: Signal,
        linear_resistance: float,
        viscosity_factor: Signal,
        linear_factor: Signal,
    ) -> Signal:
        del linear_resistance
        magnitude = abs(flow) if isinstance(flow, float) else np.abs(flow)
        return linear_factor * (
            self.laminar * viscosity_factor * flow + self.turbulent * flow * magnitude
        )


@register_effect_c
@dataclass(frozen=True)
class OrificeFlowC(FamilyCEffect, effect="orifice_flow"):
    """Needle-valve flow as a two-term law: a viscous gap in series with a sharp orifice.

    The drop is ``R_lam Q + rho Q |Q| / (2 C_d^2 A^2)`` (the Forchheimer/Idelchik two-term form,
    Merritt 1967 ch. 3): laminar in the needle's annular gap, scaling with the viscosity, and
    turbulent at its sharp exit, independent of it. At the seed's pulsing amplitude its
    describing-function resistance equals the rig file's linearised ``R_v`` (seed eq. 16),
    so the valve's mean behaviour is the rig file's and the turbulent share ``f`` shows as
    an amplitude-dependent drop and harmonics.
    """

    turbulent_share: float = 0.85

    parameters: ClassVar[tuple[Parameter, ...]] = (
        STRENGTH,
        Parameter("turbulent_share", "-", 0.1, 1.0, "share of R_v the orifice term makes at full"),
    )
    diagnosis_model: ClassVar[str] = (
        "dp = K Q |Q| alone; the truth keeps a viscous gap in series with the orifice"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> OrificeFlowC:
        """This law at ``strength``, its own parameters drawn from ``rng`` (a case's draw)."""
        return cls(strength=strength, turbulent_share=float(np.round(rng.uniform(0.6, 1.0), 3)))

    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""
        share = self.strength * self.turbulent_share
        flow = reference_flow(plant, plant.rig.excitation_hz)
        # the fundamental of Q |Q| at amplitude Q0 is 8 Q0 / (3 pi) times Q
        turbulent = share * plant.valve_resistance * 3.0 * math.pi / (8.0 * flow)
        return _TwoTermOrifice((1.0 - share) * plant.valve_resistance, turbulent)
