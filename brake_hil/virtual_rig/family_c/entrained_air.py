"""Family c's entrained air: polytropic bubbles, part of whose air is dissolved by pressure."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from brake_hil.virtual_rig.effects.base import STRENGTH, Parameter
from brake_hil.virtual_rig.family_c.base import FamilyCEffect, register_effect_c
from brake_hil.virtual_rig.laws import LtiPlant, Signal, TruthLaw

ATMOSPHERE = 1.013e5  # Pa, absolute pressure at gauge zero


@dataclass(frozen=True)
class _PolytropicBubbles(TruthLaw):
    fraction: float  # -, free-air volume fraction at gauge zero
    index: float  # -, polytropic index n (1 isothermal, 1.4 adiabatic)
    solubility: float  # -, share of the free air that dissolves per atmosphere of gauge

    def specific_compliance(self, gauge_pressure: Signal) -> Signal:
        if isinstance(gauge_pressure, float):
            p: Signal = max(gauge_pressure, 0.0) + ATMOSPHERE
        else:
            p = np.maximum(gauge_pressure, 0.0) + ATMOSPHERE
        ratio = ATMOSPHERE / p
        free = 1.0 / (1.0 + self.solubility * (p - ATMOSPHERE) / ATMOSPHERE)
        # V_air = j V free(p) (p0 / p)^(1/n); compliance per volume = -dV_air/dp / V
        volume = self.fraction * free * ratio ** (1.0 / self.index)
        dfree = self.solubility / ATMOSPHERE * free
        return volume * (1.0 / (self.index * p) + dfree)


@register_effect_c
@dataclass(frozen=True)
class EntrainedAirC(FamilyCEffect, effect="entrained_air"):
    """Entrained air as polytropic bubbles whose free share shrinks as air dissolves.

    Free air of volume fraction ``j`` at gauge zero is compressed polytropically,
    ``V ~ p^(-1/n)`` with ``n`` between isothermal (1, slow pulsing, small bubbles) and
    adiabatic (1.4); some of it goes into solution as the pressure rises (Henry's law in its
    fast limit, the free share ``1 / (1 + s p / p_atm)``), which adds to the compliance at low
    pressure and takes from it at high (seed eq. 18 linearises all this at one mean pressure).
    """

    fraction: float = 0.05
    index: float = 1.15
    solubility: float = 0.02

    parameters: ClassVar[tuple[Parameter, ...]] = (
        STRENGTH,
        Parameter("fraction", "-", 1e-4, 0.1, "free-air volume fraction at gauge zero, full"),
        Parameter("index", "-", 1.0, 1.4, "polytropic index n of the bubbles"),
        Parameter("solubility", "-", 0.0, 0.1, "share dissolved per atmosphere of gauge"),
    )
    diagnosis_model: ClassVar[str] = (
        "isothermal free air of one fraction; the truth is polytropic and part of it dissolves"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> EntrainedAirC:
        """This law at ``strength``, its own parameters drawn from ``rng`` (a case's draw)."""
        return cls(
            strength=strength,
            fraction=float(np.round(rng.uniform(0.03, 0.06), 5)),
            index=float(np.round(rng.uniform(1.0, 1.3), 3)),
            solubility=float(np.round(rng.uniform(0.0, 0.05), 4)),
        )

    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""
        del plant
        return _PolytropicBubbles(self.strength * self.fraction, self.index, self.solubility)
