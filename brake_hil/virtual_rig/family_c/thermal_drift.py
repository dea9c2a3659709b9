"""Family c's thermal drift: the rig warms toward a temperature its dissipation sets."""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import ClassVar

import numpy as np

from brake_hil.virtual_rig.effects.base import STRENGTH, Parameter
from brake_hil.virtual_rig.family_c.base import FamilyCEffect, register_effect_c
from brake_hil.virtual_rig.laws import LtiPlant, Signal, TruthLaw

VOGEL_B = 900.0  # K, the Vogel-Fulcher slope of a glycol-ether brake fluid's viscosity
VOGEL_T0 = 160.0  # K, its Vogel temperature
AMBIENT = 293.15  # K
SEAL_SOFTENING = 0.006  # 1/K, EPDM's modulus loss per kelvin above its glassy tail
EXPANSION = 7.0e-4  # 1/K, the fluid's volumetric expansion


@dataclass(frozen=True)
class _WarmingRig(TruthLaw):
    rise: float  # K, the temperature rise the dissipation would settle at
    time_constant: float  # s, the heat capacity times the thermal resistance to the room
    delay: float  # s, before the heat reaches fluid and seal

    def temperature(self, time: Signal) -> Signal:
        if isinstance(time, float):
            elapsed = max(time - self.delay, 0.0)
            return AMBIENT + self.rise * (1.0 - math.exp(-elapsed / self.time_constant))
        elapsed = np.maximum(time - self.delay, 0.0)
        return AMBIENT + self.rise * (1.0 - np.exp(-elapsed / self.time_constant))

    def drift_factors(self, time: Signal) -> tuple[Signal, Signal, Signal]:
        temperature = self.temperature(time)
        warmer = temperature - AMBIENT
        exp = math.exp if isinstance(temperature, float) else np.exp
        viscosity = exp(VOGEL_B / (temperature - VOGEL_T0) - VOGEL_B / (AMBIENT - VOGEL_T0))
        modulus = 1.0 - SEAL_SOFTENING * warmer
        valve = (1.0 - EXPANSION * warmer) ** 0.5  # an orifice's drop ~ rho
        return viscosity, modulus, valve

    def internals(self, time: Signal, states: object) -> dict[str, Signal]:
        del states
        return {"temperature": self.temperature(time)}


@register_effect_c
@dataclass(frozen=True)
class ThermalDriftC(FamilyCEffect, effect="thermal_drift"):
    """Thermal drift: a first-order warm-up of fluid and seal, viscosity on a Vogel law.

    The power dissipated in the valve, the lines and the seals (and the solenoid beside the
    caliper) heats fluid and seal through one heat capacity and one thermal resistance to the
    room, after a conduction delay: ``T = T_room + dT (1 - exp(-(t - t_d) / tau))``. The fluid's
    viscosity follows Vogel-Fulcher-Tammann (``ln mu ~ B / (T - T_0)``, glycol-ether fluid),
    the EPDM seal softens by about 0.6 %/K (``k_eh``, ``c_eh`` and the friction with it) and
    the fluid's expansion lowers the orifice drop a little.
    """

    time_constant: float = 20.0
    delay: float = 1.0

    parameters: ClassVar[tuple[Parameter, ...]] = (
        STRENGTH,
        Parameter("time_constant", "s", 2.0, 600.0, "thermal time constant tau"),
        Parameter("delay", "s", 0.0, 10.0, "conduction delay t_d before the warm-up shows"),
    )
    diagnosis_model: ClassVar[str] = (
        "linear drift rates of the line resistance and the seal; the truth warms exponentially"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> ThermalDriftC:
        """This law at ``strength``, its own parameters drawn from ``rng`` (a case's draw)."""
        return cls(
            strength=strength,
            time_constant=float(np.round(rng.uniform(8.0, 25.0), 2)),
            delay=float(np.round(rng.uniform(0.0, 3.0), 2)),
        )

    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""
        del plant
        return _WarmingRig(40.0 * self.strength, self.time_constant, self.delay)
