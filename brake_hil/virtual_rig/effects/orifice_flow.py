"""orifice_flow: the needle valve is partly a turbulent orifice (``dp ~ Q |Q|``)."""

from __future__ import annotations

from dataclasses import dataclass, replace
import math

import numpy as np

from brake_hil.physics import catalogue
from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.effects.registry import register_effect
from brake_hil.virtual_rig.laws import LtiPlant, Signal
from brake_hil.virtual_rig.mechanics import SharedValve

_QUADRATURE_POINTS = 512


def _square_gain(ratio: Signal) -> Signal:
    """``(r / (1 - exp(-r)))^2``, 1 at ``r = 0`` (the laminar limit)."""
    safe = fm.maximum(ratio, 1.0e-9)
    gain = safe / -fm.expm1(-safe)
    return gain**2


@dataclass(frozen=True)
class OrificeValve(SharedValve):
    """Needle valve bound to a rig: linear share plus a Reynolds-dependent orifice.

    The host's valve-drop port.
    """

    share: float  # s, -, orifice share of the linearised resistance
    flow_coefficient: float  # K = rho / (2 C_d_inf^2 A_o^2), Pa s^2/m^6
    transition_flow: float  # Q_t, m^3/s, flow at the transition Reynolds number

    def orifice_drop(self, flow: Signal, viscosity_factor: Signal) -> Signal:
        """Orifice pressure drop (Pa) at ``flow`` (m^3/s): ``rho Q |Q| / (2 C_d(Re)^2 A_o^2)``."""
        transition = self.transition_flow * viscosity_factor
        ratio = fm.sqrt(fm.absolute(flow) / transition)
        drop: Signal = self.flow_coefficient * transition * flow * _square_gain(ratio)
        return drop

    def own_drop(self, flow: Signal, viscosity_factor: Signal) -> Signal:
        """The valve's own drop ``dp_orifice(Q)`` (Pa): :meth:`orifice_drop`."""
        return self.orifice_drop(flow, viscosity_factor)


def describing_function_resistance(valve: OrificeValve, amplitude: float) -> float:
    """Equivalent linear resistance (Pa s/m^3) of the orifice for ``Q = amplitude sin(wt)``.

    The first Fourier coefficient of the drop over the flow amplitude (Gelb and Vander Velde,
    Multiple-Input Describing Functions, 1968): what a linearisation at that amplitude sees.
    """
    theta = (np.arange(_QUADRATURE_POINTS) + 0.5) * math.pi / _QUADRATURE_POINTS
    flow = amplitude * np.sin(theta)
    drop = valve.orifice_drop(flow, np.ones(1))
    return float(2.0 / amplitude * np.mean(drop * np.sin(theta)))


@register_effect
@dataclass(frozen=True)
class OrificeFlow(Effect):
    """Turbulent orifice flow in the needle valve.

    The seed linearises the valve about an operating drop (eqs. 15-17,
    ``R_v = 2 sqrt(gamma dp_o) / B_V``), but a needle valve's pressure drop grows with the square
    of the flow once its jet is turbulent, so its resistance rises with the flow amplitude. The
    simulator gives a share ``s`` of the valve's linearised resistance to an orifice
    ``dp = rho Q |Q| / (2 C_d(Re)^2 A_o^2)`` whose discharge coefficient rises with the jet's
    Reynolds number ``Re = 4 |Q| / (pi d_o nu)`` as ``C_d = C_d_inf (1 - exp(-sqrt(Re / Re_t)))``:
    laminar (``dp ~ Q``) near flow reversal, turbulent (``dp ~ Q |Q|``) at the flow peaks. Its size
    is set so that its describing-function resistance at the reference flow amplitude equals the
    rig's ``R_v``; the rest stays linear.
    Source: seed eqs. 15-17; Merritt, Hydraulic Control Systems (Wiley 1967), ch. 3.
    """

    strength: float = 1.0
    reference_flow: float = 2.5e-6
    orifice_diameter: float = 6.0e-4
    transition_reynolds: float = 50.0

    entry = catalogue.entry("orifice_flow")
    parameters = (
        STRENGTH,
        Parameter("reference_flow", "m^3/s", 1.0e-7, 1.0e-4, "flow amplitude at which R_v holds"),
        Parameter("orifice_diameter", "m", 1.0e-4, 3.0e-3, "d_o of the valve's jet"),
        Parameter("transition_reynolds", "-", 1.0, 2000.0, "Re_t of the C_d(Re) curve"),
    )
    diagnosis_model = (
        "a pure quadratic valve dp = K Q |Q| (plus the linear line resistance); the simulator's "
        "discharge coefficient depends on the Reynolds number (laminar near flow reversal) and "
        "only a share of the valve is an orifice"
    )

    def law(self, plant: LtiPlant) -> OrificeValve:
        """The valve of the plant's truth rig at this strength."""
        fluid = plant.rig.fluid
        kinematic = fluid.viscosity / fluid.density
        transition = self.transition_reynolds * math.pi * self.orifice_diameter * kinematic / 4.0
        unit = OrificeValve(self.strength, 1.0, transition)
        gain = describing_function_resistance(unit, self.reference_flow)
        return replace(unit, flow_coefficient=plant.valve_resistance / gain)
