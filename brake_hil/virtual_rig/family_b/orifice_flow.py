"""orifice_flow, family b: the needle valve as a laminar-turbulent blend (Churchill-Usagi)."""

from __future__ import annotations

from dataclasses import dataclass, replace
import math

import numpy as np
from scipy.optimize import brentq

from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.family_b.base import FamilyBEffect, register_effect_b
from brake_hil.virtual_rig.laws import LtiPlant, Signal
from brake_hil.virtual_rig.mechanics import SharedValve

__all__ = ["BlendedValve", "OrificeFlowB", "describing_function_resistance"]

_QUADRATURE_POINTS = 512


@dataclass(frozen=True)
class BlendedValve(SharedValve):
    """Needle valve bound to a rig: a linear share plus a blended laminar-turbulent gap (SI).

    The host's valve-drop port.
    """

    share: float  # s, -, share of the linearised resistance the blended gap takes
    laminar_resistance: float  # R_l, Pa s/m^3, laminar asymptote (at the rig's viscosity)
    turbulent_coefficient: float  # K, Pa s^2/m^6, turbulent asymptote K Q |Q|
    blend_exponent: float  # m, -, Churchill-Usagi exponent

    def blended_drop(self, flow: Signal, viscosity_factor: Signal) -> Signal:
        """``Q (R_l^m + (K |Q|)^m)^(1/m)`` (Pa) at ``flow`` (m^3/s).

        ``R_l`` scaled by the viscosity's drift factor.
        """
        laminar = self.laminar_resistance * viscosity_factor
        turbulent = self.turbulent_coefficient * fm.absolute(flow)
        exponent = self.blend_exponent
        drop: Signal = flow * (laminar**exponent + turbulent**exponent) ** (1.0 / exponent)
        return drop

    def own_drop(self, flow: Signal, viscosity_factor: Signal) -> Signal:
        """The valve's own drop ``dp_blend(Q)`` (Pa): :meth:`blended_drop`."""
        return self.blended_drop(flow, viscosity_factor)


def describing_function_resistance(valve: BlendedValve, amplitude: float) -> float:
    """Equivalent linear resistance (Pa s/m^3) of the blended gap for ``Q = amplitude sin(wt)``.

    The first Fourier coefficient of the drop over the flow amplitude (Gelb and Vander Velde,
    Multiple-Input Describing Functions, 1968).
    """
    theta = (np.arange(_QUADRATURE_POINTS) + 0.5) * math.pi / _QUADRATURE_POINTS
    flow = amplitude * np.sin(theta)
    drop = valve.blended_drop(flow, np.ones(1))
    return float(2.0 / amplitude * np.mean(drop * np.sin(theta)))


@register_effect_b
@dataclass(frozen=True)
class OrificeFlowB(FamilyBEffect, effect="orifice_flow"):
    """Turbulent orifice flow (family b): the needle valve's gap blends laminar and turbulent flow.

    The seed linearises the valve (eqs. 15-17); a needle valve's annular gap is laminar at low
    flow (``dp = R_l Q``, Hagen-Poiseuille in the gap) and turbulent at high flow
    (``dp = K Q |Q|``, a Borda-Carnot loss), crossing over near a transition Reynolds number
    ``Re* = 4 Q* / (pi d_o nu)`` with ``Q* = R_l / K``. The simulator gives a share ``s`` of the
    valve's linearised resistance to Churchill and Usagi's blend of the two asymptotes,
    ``dp = Q (R_l^m + (K |Q|)^m)^(1/m)`` (Churchill, Usagi, "A general expression for the
    correlation of rates of transfer and other phenomena", AIChE J. 18(6), 1972; Idelchik,
    Handbook of Hydraulic Resistance, ch. 4), with ``R_l`` a fixed share of ``R_v`` scaling with
    the viscosity and ``K`` set so that the blend's describing-function resistance at the
    reference flow amplitude equals ``R_v``; the rest stays linear. Unlike family a (a pure
    orifice ``rho Q |Q| / (2 C_d^2 A_o^2)`` with a Reynolds-dependent discharge coefficient) a
    laminar resistance remains at every flow and the crossover's sharpness is ``m``.
    Source: seed eqs. 15-17; Churchill and Usagi (1972).
    """

    strength: float = 1.0
    reference_flow: float = 2.5e-6
    laminar_share: float = 0.4
    blend_exponent: float = 2.0

    parameters = (
        STRENGTH,
        Parameter("reference_flow", "m^3/s", 1.0e-7, 1.0e-4, "flow amplitude at which R_v holds"),
        Parameter("laminar_share", "-", 0.05, 0.9, "R_l / R_v, the laminar asymptote"),
        Parameter("blend_exponent", "-", 1.2, 6.0, "m of the Churchill-Usagi blend"),
    )
    diagnosis_model = (
        "a pure quadratic valve dp = K Q |Q| (plus the linear line resistance); the "
        "simulator blends a laminar and a turbulent asymptote by a power mean (exponent m), "
        "and only a share of the valve is nonlinear"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> Effect:
        """Laminar share 0.25-0.55, blend exponent 1.5-3, reference flow 2-3.5e-6 m^3/s."""
        return cls(
            strength=strength,
            reference_flow=float(np.round(rng.uniform(2.0e-6, 3.5e-6), 9)),
            laminar_share=float(np.round(rng.uniform(0.25, 0.55), 3)),
            blend_exponent=float(np.round(rng.uniform(1.5, 3.0), 3)),
        )

    def law(self, plant: LtiPlant) -> BlendedValve:
        """The valve of the plant's truth rig at this strength."""
        resistance = plant.valve_resistance
        laminar = self.laminar_share * resistance
        valve = BlendedValve(self.strength, laminar, 0.0, self.blend_exponent)
        amplitude = self.reference_flow

        def excess(log_coefficient: float) -> float:
            trial = replace(valve, turbulent_coefficient=math.exp(log_coefficient))
            return describing_function_resistance(trial, amplitude) / resistance - 1.0

        scale = math.log(resistance / amplitude)  # K at which K Q* = R_v
        log_coefficient = brentq(excess, scale - 20.0, scale + 20.0, xtol=1e-10)
        return replace(valve, turbulent_coefficient=math.exp(log_coefficient))
