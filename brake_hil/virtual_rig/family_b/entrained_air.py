"""entrained_air, family b: adiabatic bubbles that dissolve completely at a critical pressure."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.effects.entrained_air import ATMOSPHERIC_PRESSURE
from brake_hil.virtual_rig.family_b.base import FamilyBEffect, register_effect_b
from brake_hil.virtual_rig.laws import LtiPlant, Signal, TruthLaw

__all__ = ["DissolvingBubbles", "EntrainedAirB"]


@dataclass(frozen=True)
class DissolvingBubbles(TruthLaw):
    """Free air bound to a strength: compliance per unit fluid volume (1/Pa).

    The host's specific-compliance port (every chamber and line node).
    """

    free_air_fraction: float  # alpha_0, -, free-gas volume share at atmospheric pressure
    polytropic_index: float  # kappa, -
    critical_pressure: float  # p_c, Pa absolute, where the last free air has dissolved

    def specific_compliance(self, gauge_pressure: Signal) -> Signal:
        """``-dV_air/dp / V`` (1/Pa) at the given gauge pressure (Pa).

        Free gas ``V_air / V = alpha_0 (p_0 / p)^(1/kappa) (1 - u)^2`` with the absolute
        pressure ``p`` (floored at 0.2 atm) and ``u = (p - p_0) / (p_c - p_0)`` clipped to 0-1.
        """
        absolute = fm.maximum(gauge_pressure + ATMOSPHERIC_PRESSURE, 0.2 * ATMOSPHERIC_PRESSURE)
        span = self.critical_pressure - ATMOSPHERIC_PRESSURE
        progress = fm.maximum(absolute - ATMOSPHERIC_PRESSURE, 0.0) / span
        left = fm.maximum(1.0 - progress, 0.0)
        gas = self.free_air_fraction * (ATMOSPHERIC_PRESSURE / absolute) ** (
            1.0 / self.polytropic_index
        )
        compliance: Signal = gas * (
            left**2 / (self.polytropic_index * absolute) + (progress > 0.0) * 2.0 * left / span
        )
        return compliance


@register_effect_b
@dataclass(frozen=True)
class EntrainedAirB(FamilyBEffect, effect="entrained_air"):
    """Entrained air (family b): adiabatic bubbles dissolving completely at a critical pressure.

    Undissolved air makes the bulk modulus of eq. 18 rise steeply with pressure. The simulator
    adds to the rig's compliance a free-gas volume compressed near-adiabatically (the bubbles of
    a 5 Hz pulse have no time to exchange heat: index ``kappa`` about 1.4) that dissolves as the
    pressure rises and is gone at a critical pressure ``p_c``: ``V_air / V = alpha_0
    (p_0 / p)^(1/kappa) (1 - (p - p_0) / (p_c - p_0))^2`` with ``p`` absolute (the critical-
    pressure air-release model of Nykanen, Esque, Ellman, "Comparison of different fluid models",
    Bath Workshop on Power Transmission and Motion Control, 2000, and Yu, Chen, Lu, "Analysis of
    air-release effects in hydraulic systems", ASME 1994); its compliance is ``-dV_air / dp`` at
    each chamber's instantaneous pressure. Unlike family a (index 1.2, Henry's law
    ``1 / (1 + (p - p_0) / p_d)`` that never dissolves all the air) the gas is stiffer and the
    free air runs out at a finite pressure. Source: seed eq. 18; Nykanen et al. (2000);
    Gholizadeh, Burton, Schoenau, Int. J. Fluid Power 12(3), 2011.
    """

    strength: float = 1.0
    free_air_fraction: float = 0.02
    polytropic_index: float = 1.4
    critical_pressure: float = 6.0e6

    parameters = (
        STRENGTH,
        Parameter("free_air_fraction", "-", 1.0e-4, 0.1, "alpha_0 at strength 1, at atmospheric"),
        Parameter("polytropic_index", "-", 1.0, 1.4, "kappa: 1 isothermal, 1.4 adiabatic"),
        Parameter("critical_pressure", "Pa", 3.5e6, 5.0e7, "p_c (absolute): all air dissolved"),
    )
    diagnosis_model = (
        "isothermal air, beta_e(p) from eq. 18 with beta_a = p (gauge or absolute) and a "
        "constant air fraction; the simulator's bubbles are near-adiabatic and dissolve "
        "completely at a critical pressure"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> Effect:
        """Free air 1.5-3 %, index 1.3-1.4, critical pressure 4-8 MPa."""
        return cls(
            strength=strength,
            free_air_fraction=float(np.round(rng.uniform(0.015, 0.03), 4)),
            polytropic_index=float(np.round(rng.uniform(1.3, 1.4), 3)),
            critical_pressure=float(np.round(rng.uniform(4.0e6, 8.0e6), -3)),
        )

    def law(self, plant: LtiPlant) -> DissolvingBubbles:
        """The free-air law at this strength (the same on every rig)."""
        del plant
        return DissolvingBubbles(
            free_air_fraction=self.strength * self.free_air_fraction,
            polytropic_index=self.polytropic_index,
            critical_pressure=self.critical_pressure,
        )
