"""Mechanics both families of truth laws share, written once.

Family a (:mod:`brake_hil.virtual_rig.effects`) and family b
(:mod:`brake_hil.virtual_rig.family_b`) realise each effect by structurally different laws,
but the way a law sits on the host's port is often the same: a valve law takes a share of the
linearised resistance, a frictional seal law a share of the seal force with its own shear
deflection, a groove law shifts the seal spring about a relaxed position that moves, a bore
friction law presses the piston on its bore by the caliper's cocking, the fluid warms up
from ambient with a time constant. Those skeletons are
here; each family's law fills in only its own physics (a hook of a few lines).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
import math

import numpy as np

from brake_hil.physics.parameters import ModelParameters
from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.laws import SealPorts, Signal, State, TruthLaw

__all__ = [
    "ASYMMETRY_WIDTH_SHARE",
    "CockedContact",
    "FrictionalSeal",
    "RelaxingGroove",
    "SharedValve",
    "asymmetric_limit",
    "heated_temperature",
    "smooth_speed",
    "structural_damping",
]

SPEED_SMOOTHING = 2.0e-5
"""Velocity (m/s) below which ``|v|`` is rounded off, ``sqrt(v^2 + e^2) - e``."""
ASYMMETRY_WIDTH_SHARE = 0.25
"""Width of the apply/release switch of an asymmetric seal, as a share of its slip deflection."""
_DEFLECTION_SMOOTHING = 1.0e-7
"""Caliper displacement (m) below which ``|x_c|`` is rounded off."""


def smooth_speed(velocity: Signal) -> Signal:
    """``|v|`` rounded off below :data:`SPEED_SMOOTHING` (m/s), so the law is differentiable."""
    return fm.sqrt(velocity**2 + SPEED_SMOOTHING**2) - SPEED_SMOOTHING


def asymmetric_limit(limit: Signal, asymmetry: float, deflection: Signal, width: float) -> Signal:
    """A seal's slip limit ``(1 - a)`` as large on apply (``z > 0``), ``(1 + a)`` on release.

    Switched smoothly over ``width`` (m) of the deflection ``z`` (m).
    """
    scaled: Signal = limit * (1.0 - asymmetry * fm.tanh(deflection / width))
    return scaled


def heated_temperature(time: Signal, ambient: float, rise: float, time_constant: float) -> Signal:
    """``T_0 + dT (1 - exp(-t / tau))`` (K): a first-order warm-up from ``ambient`` (K).

    ``time`` in s from the start (none before it), the plateau ``rise`` (K) above ambient.
    """
    fraction = -fm.expm1(-fm.maximum(time, 0.0) / time_constant)
    temperature: Signal = ambient + rise * fraction
    return temperature


def structural_damping(params: ModelParameters, ratio: float) -> tuple[float, float]:
    """Damping (N s/m) of caliper to ground and piston to block at damping ratio ``ratio``.

    ``2 zeta sqrt(k M)`` on ``k_c`` and ``k_k``, with ``ratio = 2 zeta``: what a seal law that
    replaces ``c_eh`` keeps of the structure's own damping.
    """
    caliper = ratio * math.sqrt(params.caliper_stiffness * params.caliper_mass)
    block = ratio * math.sqrt(params.block_stiffness * params.piston_mass)
    return caliper, block


class SharedValve(TruthLaw):
    """A needle-valve law that takes a share ``s`` of the linearised resistance (the valve port).

    The drop is ``(1 - s) R_v Q + s dp(Q)``; a law gives ``share`` and :meth:`own_drop`.
    """

    share: float  # s, -

    def own_drop(self, flow: Signal, viscosity_factor: Signal) -> Signal:
        """The law's own pressure drop (Pa) at ``flow`` (m^3/s)."""
        raise NotImplementedError

    def valve_drop(
        self,
        flow: Signal,
        linear_resistance: float,
        viscosity_factor: Signal,
        linear_factor: Signal,
    ) -> Signal:
        """Valve drop (Pa): ``(1 - s) R_v Q + s dp(Q)``.

        ``R_v`` is the rig's linearised resistance (Pa s/m^3).
        """
        drop: Signal = (1.0 - self.share) * linear_resistance * linear_factor * flow + (
            self.share * self.own_drop(flow, viscosity_factor)
        )
        return drop


class FrictionalSeal(TruthLaw):
    """A seal law carrying a share of the seal force, its state the seals' shear deflection.

    The seal-force port: ``(1 - share) F_spring + share F_own``; what ``c_eh`` lumped of the
    structure's damping stays as ``caliper_damping`` and ``block_damping``. A law gives these
    fields, :meth:`own_force` and :meth:`rest_limit`.
    """

    share: float  # -, share of the seal force this law carries (the rest: k_eh, c_eh)
    caliper_damping: float  # N s/m, caliper to ground, kept where c_eh is replaced
    block_damping: float  # N s/m, piston to block (load cells)

    def own_force(self, deflection: Signal, seal: SealPorts) -> tuple[Signal, Signal]:
        """The law's own seal force (N) and the rate ``z'`` (m/s) of the deflection ``z`` (m)."""
        raise NotImplementedError

    def rest_limit(self) -> float:
        """Largest shear deflection (m) the seals keep at rest."""
        raise NotImplementedError

    def states(self) -> tuple[State, ...]:
        """The seals' shear deflection ``z`` (m)."""
        return (State("z", 1e-5),)

    def initial_state(self, equilibrium: Mapping[str, float]) -> tuple[float, ...]:
        """At rest the seals are sheared by the seal displacement, within :meth:`rest_limit`."""
        limit = self.rest_limit()
        return (float(np.clip(equilibrium["seal_displacement"], -limit, limit)),)

    def spring_share(self) -> float:
        """What the equivalent spring and damper keep: ``1 - share``."""
        return 1.0 - self.share

    def seal_force(self, seal: SealPorts, states: Sequence[Signal]) -> tuple[Signal, list[Signal]]:
        """``(1 - share) F_spring + share F_own`` (N), and ``z'`` (m/s)."""
        own, rate = self.own_force(states[0], seal)
        force = (1.0 - self.share) * seal.spring_force + self.share * own
        return force, [rate]

    def structural_damping(self) -> tuple[float, float]:
        """Caliper to ground and piston to block (N s/m)."""
        return self.caliper_damping, self.block_damping


class RelaxingGroove(TruthLaw):
    """A groove law: the seal spring deflects about a relaxed position ``x_r`` that moves.

    The spring-deflection port (state ``x_r``) and the seal's apply/release asymmetry. A law
    gives ``asymmetry``, :meth:`groove_deflection` and :meth:`relaxation_rate`.
    """

    asymmetry: float  # a, -

    def groove_deflection(self, deflection: Signal) -> Signal:
        """The spring's effective deflection (m) beyond ``x_r`` at ``e = x_s - x_r`` (m)."""
        raise NotImplementedError

    def relaxation_rate(self, deflection: Signal) -> Signal:
        """``x_r'`` (m/s) at ``e = x_s - x_r`` (m)."""
        raise NotImplementedError

    def states(self) -> tuple[State, ...]:
        """The seal's relaxed position ``x_r`` (m)."""
        return (State("x_r", 1e-5),)

    def initial_state(self, equilibrium: Mapping[str, float]) -> tuple[float, ...]:
        """At rest the seal is relaxed where it sits."""
        return (equilibrium["seal_displacement"],)

    def seal_asymmetry(self) -> float:
        """``a``, for a frictional seal's slip threshold."""
        return self.asymmetry

    def spring_deflection(
        self, seal_displacement: Signal, states: Sequence[Signal]
    ) -> tuple[Signal, list[Signal]]:
        """``x_r + groove_deflection(e)`` (m) with ``e = x_s - x_r``, and ``x_r'``."""
        relaxed = states[0]
        deflection = seal_displacement - relaxed
        effective = relaxed + self.groove_deflection(deflection)
        return effective, [self.relaxation_rate(deflection)]


class CockedContact(TruthLaw):
    """A bore-friction law's contact: the cocked caliper presses the piston on its bore.

    A law gives ``guide_length`` and ``bore_area``.
    """

    guide_length: float  # l_g, m
    bore_area: float  # A_eb, m^2

    def normal_force(self, bore_pressure: Signal, caliper_displacement: Signal) -> Signal:
        """Contact force from cocking ``4 A_eb p_b |x_c| / l_g`` (N), seed eq. 8 on ``l_g``.

        ``|x_c|`` smoothed over ``_DEFLECTION_SMOOTHING`` (m); pressure below gauge zero gives
        none.
        """
        tilt = fm.sqrt(caliper_displacement**2 + _DEFLECTION_SMOOTHING**2)
        force: Signal = (
            4.0 * self.bore_area * fm.maximum(bore_pressure, 0.0) * tilt / self.guide_length
        )
        return force
