"""entrained_air: free air in the fluid makes the bulk modulus rise with pressure."""

from __future__ import annotations

from dataclasses import dataclass

from brake_hil.physics import catalogue
from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.effects.registry import register_effect
from brake_hil.virtual_rig.laws import LtiPlant, Signal, TruthLaw

ATMOSPHERIC_PRESSURE = 101_325.0
"""Absolute pressure (Pa) at zero gauge pressure, where the free-air fraction is given."""


@dataclass(frozen=True)
class PolytropicAir(TruthLaw):
    """Free air bound to a strength: compliance per unit fluid volume (1/Pa).

    The host's specific-compliance port (every chamber and line node).
    """

    free_air_fraction: float  # alpha_0, -, free-gas volume share at atmospheric pressure
    polytropic_index: float  # n, -
    dissolution_pressure: float  # p_d, Pa

    def specific_compliance(self, gauge_pressure: Signal) -> Signal:
        """``-dV_air/dp / V`` (1/Pa) at the given gauge pressure (Pa).

        Free gas ``V_air / V = alpha_0 (p_0 / p)^(1/n) h(p)`` with the absolute pressure ``p``
        (floored at 0.2 atm) and the dissolved share ``h = 1 / (1 + max(p - p_0, 0) / p_d)``.
        """
        absolute = fm.maximum(gauge_pressure + ATMOSPHERIC_PRESSURE, 0.2 * ATMOSPHERIC_PRESSURE)
        excess = fm.maximum(absolute - ATMOSPHERIC_PRESSURE, 0.0)
        free = 1.0 / (1.0 + excess / self.dissolution_pressure)
        dissolving = (excess > 0.0) * free / self.dissolution_pressure
        gas = self.free_air_fraction * (ATMOSPHERIC_PRESSURE / absolute) ** (
            1.0 / self.polytropic_index
        )
        compliance: Signal = gas * free * (1.0 / (self.polytropic_index * absolute) + dissolving)
        return compliance


@register_effect
@dataclass(frozen=True)
class EntrainedAir(Effect):
    """Entrained air: undissolved air bubbles in the brake fluid.

    They make the effective bulk modulus of eq. 18 rise steeply with pressure, so the bore chamber
    (and the master cylinder and line) are soft at low pressure and stiff at high pressure. The
    simulator adds to the rig's own compliance a free-gas volume ``alpha_0 (p_0 / p)^(1/n) h(p) V``
    compressed polytropically (index ``n`` between isothermal 1 and adiabatic 1.4) and partly
    dissolving by Henry's law (``h = 1 / (1 + (p - p_0) / p_d)``), with ``p`` absolute; its
    compliance is ``-dV_air / dp`` at the instantaneous pressure of each chamber.
    Source: seed eq. 18 (isothermal air at the mean pressure); Merritt, Hydraulic Control Systems
    (Wiley 1967), ch. 2; Gholizadeh, Burton, Schoenau, "Fluid bulk modulus: a literature survey",
    Int. J. Fluid Power 12(3), 2011.
    """

    strength: float = 1.0
    free_air_fraction: float = 0.02
    polytropic_index: float = 1.2
    dissolution_pressure: float = 5.0e6

    entry = catalogue.entry("entrained_air")
    parameters = (
        STRENGTH,
        Parameter("free_air_fraction", "-", 1.0e-4, 0.1, "alpha_0 at strength 1, at atmospheric"),
        Parameter("polytropic_index", "-", 1.0, 1.4, "n: 1 isothermal, 1.4 adiabatic"),
        Parameter("dissolution_pressure", "Pa", 5.0e5, 1.0e8, "p_d of the dissolved share"),
    )
    diagnosis_model = (
        "isothermal air, beta_e(p) from eq. 18 with beta_a = p (gauge or absolute) and a "
        "constant air fraction; the simulator is polytropic (n = 1.2), uses absolute "
        "pressure and lets the free-air fraction fall with pressure (Henry's law)"
    )

    def law(self, plant: LtiPlant) -> PolytropicAir:
        """The free-air law at this strength (the same on every rig)."""
        del plant
        return PolytropicAir(
            free_air_fraction=self.strength * self.free_air_fraction,
            polytropic_index=self.polytropic_index,
            dissolution_pressure=self.dissolution_pressure,
        )
