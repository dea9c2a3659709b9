"""thermal_drift: the rig warms during the recording; viscosity and seal modulus drift."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from brake_hil.physics import catalogue
from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.effects.registry import register_effect
from brake_hil.virtual_rig.laws import LtiPlant, Signal, TruthLaw
from brake_hil.virtual_rig.mechanics import heated_temperature

_LOWEST_MODULUS_FACTOR = 0.2


@dataclass(frozen=True)
class HeatingLaw(TruthLaw):
    """Temperature and the parameter factors it drives, as functions of time (SI).

    The host's drift port.
    """

    ambient_temperature: float  # T_0, K
    temperature_rise: float  # dT, K (already scaled by strength)
    time_constant: float  # tau_th, s
    andrade_temperature: float  # B, K
    seal_modulus_coefficient: float  # alpha_E, 1/K
    valve_viscosity_exponent: float  # chi, -

    def temperature(self, time: Signal) -> Signal:
        """``T(t) = T_0 + dT (1 - exp(-t / tau_th))`` (K), ``t`` in s from the start."""
        return heated_temperature(
            time, self.ambient_temperature, self.temperature_rise, self.time_constant
        )

    def viscosity_factor(self, time: Signal) -> Signal:
        """``mu(T) / mu(T_0) = exp(B (1/T - 1/T_0))`` (Andrade)."""
        inverse = 1.0 / self.temperature(time) - 1.0 / self.ambient_temperature
        factor: Signal = fm.exp(self.andrade_temperature * inverse)
        return factor

    def modulus_factor(self, time: Signal) -> Signal:
        """``E_s(T) / E_s(T_0) = 1 + alpha_E (T - T_0)`` (floored at 0.2)."""
        change = self.seal_modulus_coefficient * (
            self.temperature(time) - self.ambient_temperature
        )
        factor: Signal = fm.maximum(1.0 + change, _LOWEST_MODULUS_FACTOR)
        return factor

    def drift_factors(self, time: Signal) -> tuple[Signal, Signal, Signal]:
        """Viscosity, seal-modulus and valve factors at ``time`` (s), one temperature."""
        temperature = self.temperature(time)
        inverse = 1.0 / temperature - 1.0 / self.ambient_temperature
        viscosity = fm.exp(self.andrade_temperature * inverse)
        change = self.seal_modulus_coefficient * (temperature - self.ambient_temperature)
        modulus = fm.maximum(1.0 + change, _LOWEST_MODULUS_FACTOR)
        return viscosity, modulus, viscosity**self.valve_viscosity_exponent

    def valve_factor(self, time: Signal) -> Signal:
        """Factor on the linearised valve resistance, ``(mu / mu_0)^chi``."""
        factor: Signal = self.viscosity_factor(time) ** self.valve_viscosity_exponent
        return factor

    def internals(self, time: Signal, states: Sequence[Signal]) -> dict[str, Signal]:
        """The temperature (K)."""
        del states
        return {"temperature": self.temperature(time)}


@register_effect
@dataclass(frozen=True)
class ThermalDrift(Effect):
    """Thermal drift: repeated pulsing warms the fluid and the seals during a recording.

    The brake fluid's viscosity then falls (the line's laminar resistances ``R_r``, ``R_t`` of
    eq. 13 and the valve's viscous part drop) and the EPDM seal softens (``E_s`` of eqs. 2-3, hence
    ``k_s``, ``F_fs`` and ``k_eh``, ``c_eh`` drop), and a model identified at the start drifts away
    from the rig. The simulator heats by a first-order law ``T = T_0 + dT (1 - exp(-t / tau_th))``
    (lumped thermal capacity, Newton cooling), scales the viscosity by Andrade's law
    ``mu ~ exp(B / T)`` (Andrade, "The viscosity of liquids", Nature 125, 1930), the valve's linear
    resistance by ``(mu / mu_0)^chi`` and every seal stiffness and friction threshold by
    ``1 + alpha_E (T - T_0)`` (Gent, Engineering with Rubber, Hanser 2012).
    Source: seed eqs. 2-3, 13 and its list of physics left out (temperature).
    """

    strength: float = 1.0
    temperature_rise: float = 40.0
    time_constant: float = 15.0
    andrade_temperature: float = 2500.0
    seal_modulus_coefficient: float = -0.006
    valve_viscosity_exponent: float = 0.5
    ambient_temperature: float = 293.15

    entry = catalogue.entry("thermal_drift")
    parameters = (
        STRENGTH,
        Parameter("temperature_rise", "K", 1.0, 80.0, "dT at strength 1"),
        Parameter("time_constant", "s", 1.0, 600.0, "tau_th of the heating law"),
        Parameter("andrade_temperature", "K", 500.0, 5000.0, "B of mu ~ exp(B / T)"),
        Parameter("seal_modulus_coefficient", "1/K", -0.02, 0.01, "alpha_E of the seal"),
        Parameter("valve_viscosity_exponent", "-", 0.0, 1.0, "chi, valve's viscous share"),
        Parameter("ambient_temperature", "K", 250.0, 350.0, "T_0 at the start"),
    )
    diagnosis_model = (
        "parameters (k_eh, c_eh, line resistance) drifting linearly or exponentially in time; "
        "the simulator drives them from one temperature through Andrade's exponential law and "
        "a linear seal-modulus coefficient"
    )

    def law(self, plant: LtiPlant) -> HeatingLaw:
        """The heating law at this strength (the same on every rig)."""
        del plant
        return HeatingLaw(
            ambient_temperature=self.ambient_temperature,
            temperature_rise=self.strength * self.temperature_rise,
            time_constant=self.time_constant,
            andrade_temperature=self.andrade_temperature,
            seal_modulus_coefficient=self.seal_modulus_coefficient,
            valve_viscosity_exponent=self.valve_viscosity_exponent,
        )
