"""thermal_drift, family b: fluid and seal warm as a two-node thermal network."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
import math

import numpy as np

from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.family_b.base import FamilyBEffect, register_effect_b
from brake_hil.virtual_rig.laws import LtiPlant, Signal, TruthLaw
from brake_hil.virtual_rig.mechanics import heated_temperature

__all__ = ["ThermalDriftB", "TwoNodeHeating", "walther_viscosity"]

WALTHER_OFFSET = 0.7
"""cSt added to the kinematic viscosity in Walther's equation (ASTM D341)."""
_CENTISTOKES = 1.0e6  # cSt per m^2/s
_TIME_CONSTANT_GAP = 1.0e-3  # relative: seal and fluid time constants closer are made this far


def _log10(value: Signal) -> Signal:
    return math.log10(value) if isinstance(value, float) else np.log10(value)


def walther_viscosity(temperature: Signal, intercept: float, slope: float) -> Signal:
    """Kinematic viscosity (cSt) by Walther's equation (ASTM D341) at ``temperature`` (K).

    ``log10 log10(nu + 0.7) = A - B log10 T`` with ``A`` = ``intercept``, ``B`` = ``slope``.
    """
    viscosity: Signal = 10.0 ** (10.0 ** (intercept - slope * _log10(temperature))) - (
        WALTHER_OFFSET
    )
    return viscosity


@dataclass(frozen=True)
class TwoNodeHeating(TruthLaw):
    """Fluid and seal temperatures and the parameter factors they drive, over time (SI).

    The host's drift port.
    """

    ambient_temperature: float  # T_0, K
    temperature_rise: float  # dT, K (already scaled by strength), the plateau
    fluid_time_constant: float  # tau_f, s
    seal_time_constant: float  # tau_s, s (differs from tau_f)
    walther_intercept: float  # A, -
    walther_slope: float  # B, -
    seal_modulus_exponent: float  # beta_E, 1/K
    valve_viscosity_exponent: float  # chi, -

    def fluid_temperature(self, time: Signal) -> Signal:
        """``T_f = T_0 + dT (1 - exp(-t / tau_f))`` (K), ``t`` in s from the start."""
        return heated_temperature(
            time, self.ambient_temperature, self.temperature_rise, self.fluid_time_constant
        )

    def seal_temperature(self, time: Signal) -> Signal:
        """``T_s`` (K): the seal heated by the fluid, ``tau_s T_s' = T_f - T_s``.

        ``T_s = T_0 + dT (1 - (tau_f e^(-t/tau_f) - tau_s e^(-t/tau_s)) / (tau_f - tau_s))``.
        """
        t = fm.maximum(time, 0.0)
        fluid, seal = self.fluid_time_constant, self.seal_time_constant
        lag = (fluid * fm.exp(-t / fluid) - seal * fm.exp(-t / seal)) / (fluid - seal)
        temperature: Signal = self.ambient_temperature + self.temperature_rise * (1.0 - lag)
        return temperature

    def viscosity_factor(self, time: Signal) -> Signal:
        """``nu(T_f) / nu(T_0)`` (-) by Walther's equation."""
        now = walther_viscosity(
            self.fluid_temperature(time), self.walther_intercept, self.walther_slope
        )
        start = walther_viscosity(
            self.ambient_temperature, self.walther_intercept, self.walther_slope
        )
        factor: Signal = now / start
        return factor

    def drift_factors(self, time: Signal) -> tuple[Signal, Signal, Signal]:
        """Viscosity (fluid node), seal-modulus (seal node) and valve factors at ``time`` (s)."""
        viscosity = self.viscosity_factor(time)
        rise = self.seal_temperature(time) - self.ambient_temperature
        modulus = fm.exp(self.seal_modulus_exponent * rise)
        return viscosity, modulus, viscosity**self.valve_viscosity_exponent

    def internals(self, time: Signal, states: Sequence[Signal]) -> dict[str, Signal]:
        """The fluid's and the seal's temperatures (K)."""
        del states
        return {
            "fluid_temperature": self.fluid_temperature(time),
            "seal_temperature": self.seal_temperature(time),
        }


@register_effect_b
@dataclass(frozen=True)
class ThermalDriftB(FamilyBEffect, effect="thermal_drift"):
    """Thermal drift (family b): the fluid warms first, the seals after it, through a network.

    Pulsing throttles fluid in the valve and rubs the seals, so the rig warms during a
    recording: the fluid's viscosity falls (eq. 13's ``R_r``, ``R_t`` and the valve's viscous
    part) and the EPDM seal softens (``E_s`` of eqs. 2-3, hence ``k_s``, ``F_fs``, ``k_eh``,
    ``c_eh``). The simulator heats two lumped thermal capacities in series (a thermal RC
    network, Incropera and DeWitt, Fundamentals of Heat and Mass Transfer, ch. 5): the fluid
    ``T_f = T_0 + dT (1 - exp(-t / tau_f))``, and the seal fed by the fluid,
    ``tau_s T_s' = T_f - T_s``, an S-shaped rise that starts flat; the kinematic viscosity
    follows Walther's equation ``log log(nu + 0.7) = A - B log T`` (ASTM D341, the standard
    for hydraulic and brake fluids) at ``T_f``, the valve's linear resistance
    ``(nu / nu_0)^chi``, and every seal stiffness and threshold ``exp(beta_E (T_s - T_0))``
    (an Arrhenius-type softening of rubber, Gent, Engineering with Rubber, Hanser 2012).
    Unlike family a (one first-order temperature, Andrade's ``exp(B / T)`` and a linear seal
    modulus) the seal lags the fluid and starts drifting late. Source: seed eqs. 2-3, 13 and
    its list of physics left out (temperature); ASTM D341.
    """

    strength: float = 1.0
    temperature_rise: float = 45.0
    fluid_time_constant: float = 10.0
    seal_time_constant: float = 6.0
    walther_slope: float = 3.1
    seal_modulus_exponent: float = -0.008
    valve_viscosity_exponent: float = 0.5
    ambient_temperature: float = 293.15

    parameters = (
        STRENGTH,
        Parameter("temperature_rise", "K", 1.0, 80.0, "dT, the plateau at strength 1"),
        Parameter("fluid_time_constant", "s", 1.0, 600.0, "tau_f of the fluid node"),
        Parameter("seal_time_constant", "s", 1.0, 600.0, "tau_s of the seal node"),
        Parameter("walther_slope", "-", 1.5, 5.0, "B of Walther's equation"),
        Parameter("seal_modulus_exponent", "1/K", -0.03, 0.0, "beta_E of the seal modulus"),
        Parameter("valve_viscosity_exponent", "-", 0.0, 1.0, "chi, valve's viscous share"),
        Parameter("ambient_temperature", "K", 250.0, 350.0, "T_0 at the start"),
    )
    diagnosis_model = (
        "parameters (k_eh, c_eh, line resistance) drifting linearly or exponentially in time; "
        "the simulator drives the line from the fluid's temperature (Walther's equation) and "
        "the seal from a second, lagging temperature"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> Effect:
        """Rise 35-55 K, ``tau_f`` 6-15 s, ``tau_s`` 3-10 s, Walther ``B`` 2.6-3.6.

        And ``beta_E`` -0.01 to -0.006 1/K; each uniformly, at ``strength``.
        """
        return cls(
            strength=strength,
            temperature_rise=float(np.round(rng.uniform(35.0, 55.0), 2)),
            fluid_time_constant=float(np.round(rng.uniform(6.0, 15.0), 2)),
            seal_time_constant=float(np.round(rng.uniform(3.0, 10.0), 2)),
            walther_slope=float(np.round(rng.uniform(2.6, 3.6), 3)),
            seal_modulus_exponent=float(np.round(rng.uniform(-0.01, -0.006), 5)),
        )

    def law(self, plant: LtiPlant) -> TwoNodeHeating:
        """The heating law at this strength, Walther's ``A`` from the rig's fluid at ``T_0``."""
        fluid = plant.rig.fluid
        viscosity = fluid.viscosity / fluid.density * _CENTISTOKES
        intercept = math.log10(math.log10(viscosity + WALTHER_OFFSET)) + self.walther_slope * (
            math.log10(self.ambient_temperature)
        )
        seal_time = self.seal_time_constant
        if abs(seal_time - self.fluid_time_constant) < _TIME_CONSTANT_GAP * seal_time:
            seal_time *= 1.0 + 2.0 * _TIME_CONSTANT_GAP
        return TwoNodeHeating(
            ambient_temperature=self.ambient_temperature,
            temperature_rise=self.strength * self.temperature_rise,
            fluid_time_constant=self.fluid_time_constant,
            seal_time_constant=seal_time,
            walther_intercept=intercept,
            walther_slope=self.walther_slope,
            seal_modulus_exponent=self.seal_modulus_exponent,
            valve_viscosity_exponent=self.valve_viscosity_exponent,
        )
