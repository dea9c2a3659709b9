"""How the truth host takes effects: its physical ports and the hooks a truth law implements.

The host (:mod:`~brake_hil.virtual_rig.plant` and :mod:`~brake_hil.virtual_rig.simulator`)
integrates the seed's rig (eq. 21) and knows no effect by name. It defines its physical
*ports* once; a *truth law* is an object that implements the hooks of the ports it acts on,
and the host calls only the hooks a law overrides (every default is neutral: calling it
would change nothing). An effect (:class:`~brake_hil.virtual_rig.effects.base.Effect`)
binds its law to the truth rig's coefficients (:class:`LtiPlant`) once per run.

Ports, and how the host combines several laws on one port:

====================  =========================================================  ===========
port (hook)           what the law says                                          several
====================  =========================================================  ===========
drift_factors         viscosity, seal-modulus and valve factors over time         product
specific_compliance   extra compliance per unit fluid volume at a pressure        sum
valve_drop            the needle valve's pressure drop (replaces ``R_v Q``)       one only
line_flow             the line between valve and bore, with its own states        one only
seal_asymmetry        apply/release asymmetry a frictional seal law applies       sum
spring_deflection     the seal spring's effective deflection, own states          one only
seal_force            the seal force made of the spring's, own states             one only
structural_damping    damping caliper to ground and piston to block               sum
bore_force            a force between piston and bore, own states                 sum
caliper_share         the caliper's share of the pressure force ``A_eb p_b``      product
acquisition           a channel's measurement chain before noise and the ADC      in order
internals             signals no sensor sees, for the run's internals             merged
====================  =========================================================  ===========

A law's own states (:meth:`TruthLaw.states`) are driven by the one stateful hook it
implements (``line_flow``, ``seal_force``, ``spring_deflection`` or ``bore_force``); the host
lays them out in that order of ports, after ``Q_h`` for the line and after ``x_c'`` for the
others, and hands each law its states' SI values (and takes their rates) as lists.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple, TypeAlias

from brake_hil.errors import EffectError
from brake_hil.physics.parameters import ModelParameters
from brake_hil.physics.rig import Rig
from brake_hil.types import FloatArray

__all__ = [
    "EXCLUSIVE_HOOKS",
    "HOOKS",
    "STATEFUL_HOOKS",
    "LineFlow",
    "LinePorts",
    "LtiPlant",
    "SealPorts",
    "Signal",
    "State",
    "TruthLaw",
    "check_ports",
    "hooked",
    "implements",
]

Signal: TypeAlias = Any
"""A float or a float array (SI units as stated): every law runs on one state (Python floats,
the fast path of the solver) or on many at once (arrays: Jacobians, outputs)."""


@dataclass(frozen=True)
class LtiPlant:
    """The truth rig as eq. 21 has it, the line split into pipe, valve and hose (SI).

    What every truth law is bound to; the host's
    :class:`~brake_hil.virtual_rig.plant.Plant` adds the installed laws.
    """

    rig: Rig  # the truth rig
    params: ModelParameters  # eq. 21 coefficients at ``operating_pressure``
    operating_pressure: float  # Pa, mean master-cylinder pressure the coefficients are at
    pipe_resistance: float  # R_r, Pa s/m^3 (eq. 13)
    valve_resistance: float  # R_v, Pa s/m^3 (linearised, eqs. 15-17)
    hose_resistance: float  # R_t, Pa s/m^3 (eq. 13)
    pipe_inertance: float  # I_r, Pa s^2/m^3 (eq. 14)
    hose_inertance: float  # I_t, Pa s^2/m^3 (eq. 14)
    master_volume: float  # V_i, m^3 (eq. 19)
    bore_volume: float  # V_b, m^3 (eq. 20)
    master_damping: float = 0.0  # c_i, N s/m, on the master piston (not in eq. 21a)


class State(NamedTuple):
    """One state a law adds to the plant: its name and its scale (SI, the solver's unit)."""

    name: str
    scale: float


@dataclass(frozen=True)
class LinePorts:
    """What the host hands the line port at one instant (SI): the line's ends and makings."""

    master_pressure: Signal  # p_i, Pa
    bore_pressure: Signal  # p_b, Pa
    flow: Signal  # Q_h, m^3/s: the host's state through pipe and valve (the whole inertance)
    upstream_drop: Signal  # pressure drop over hard pipe and valve, Pa
    hose_resistance: Signal  # R_t at the present viscosity, Pa s/m^3
    inertance: float  # I_r + I_t, Pa s^2/m^3
    fluid_compliance: Signal  # per unit volume: fluid and the rig's own air (eq. 18), 1/Pa
    extra_compliance: Callable[[Signal], Signal] | None  # the laws' extra, per unit volume

    def compliance_at(self, pressure: Signal) -> Signal:
        """Compliance per unit volume (1/Pa) at ``pressure`` (Pa): the fluid's plus the laws'."""
        if self.extra_compliance is None:
            return self.fluid_compliance
        return self.fluid_compliance + self.extra_compliance(pressure)

    def lumped_rate(self, hose_drop: Signal) -> Signal:
        """``dQ_h/dt`` (m^3/s^2) of eq. 21c: ``(p_i - p_b - dp_upstream - dp_hose) / I``."""
        return (
            self.master_pressure - self.bore_pressure - self.upstream_drop - hose_drop
        ) / self.inertance


@dataclass(frozen=True)
class SealPorts:
    """What the host hands the seal-force port at one instant (SI)."""

    spring_force: Signal  # E(t) (k_eh x_eff + c_eh v), N (eqs. 21e-f)
    velocity: Signal  # seal velocity x_p' - x_c', m/s
    asymmetry: float  # the seal's apply/release asymmetry (seal_asymmetry, summed), -
    modulus_factor: Signal  # the seal modulus's drift factor, -
    viscosity_factor: Signal  # the fluid viscosity's drift factor, -


LineFlow: TypeAlias = tuple[Signal, list[Signal], Signal, Signal]
"""The ``line_flow`` hook's answer (SI): ``dQ_h/dt`` (m^3/s^2), the own states' rates, the
flow entering the bore chamber (m^3/s) and the compliance the line adds to it (m^3/Pa)."""


class TruthLaw:
    """Base of every truth law: the host's hooks, each with a neutral default.

    A law overrides the hooks of the ports it acts on (see the module docstring). The
    defaults change nothing: those of ``valve_drop`` and ``line_flow`` are the host's own
    linear valve and lumped line (the host calls the first when no law replaces the valve and
    evaluates the second inline); it calls no other default. Laws are immutable values bound
    to one :class:`LtiPlant`.
    """

    def states(self) -> tuple[State, ...]:
        """The law's own states (none by default)."""
        return ()

    def initial_state(self, equilibrium: Mapping[str, float]) -> tuple[float, ...]:
        """The own states' SI values at rest, given the LTI model's equilibrium.

        Args:
            equilibrium: eq. 21's states by name (``p_b``, ``x_p``, ``x_c`` ...) and
                ``seal_displacement`` (``x_p - x_c``, m).
        """
        del equilibrium
        return tuple(0.0 for _ in self.states())

    def drift_factors(self, time: Signal) -> tuple[Signal, Signal, Signal]:
        """Drift factors (-) at ``time`` (s from the start).

        Factors on the fluid viscosity, the seal modulus and the linearised valve resistance.
        """
        del time
        return 1.0, 1.0, 1.0

    def specific_compliance(self, gauge_pressure: Signal) -> Signal:
        """Compliance (1/Pa) per unit fluid volume this law adds at ``gauge_pressure`` (Pa)."""
        del gauge_pressure
        return 0.0

    def valve_drop(
        self,
        flow: Signal,
        linear_resistance: float,
        viscosity_factor: Signal,
        linear_factor: Signal,
    ) -> Signal:
        """The needle valve's pressure drop (Pa) at ``flow`` (m^3/s).

        The default is the host's own valve, linear: ``R_v * linear_factor * flow`` with the
        linearised ``linear_resistance`` ``R_v`` (Pa s/m^3, eqs. 15-17) and the drift's valve
        factor; ``viscosity_factor`` is the fluid viscosity's drift factor (-).
        """
        del viscosity_factor
        return linear_resistance * linear_factor * flow

    def line_flow(self, line: LinePorts, states: Sequence[Signal]) -> LineFlow:
        """The line from the valve outlet to the bore, with the law's own states.

        The default is the host's own line, lumped (eq. 21c):
        ``I Q_h' = p_i - p_b - dp_upstream - R_t Q_h``, all of ``Q_h`` entering the bore.

        Args:
            line: the line's ends, flow and makings at this instant (:class:`LinePorts`).
            states: the law's own states (SI).

        Returns:
            ``(dQ_h/dt, own states' rates, flow into the bore, compliance added to the bore)``.
        """
        del states
        return line.lumped_rate(line.hose_resistance * line.flow), [], line.flow, 0.0

    def seal_asymmetry(self) -> float:
        """Apply/release asymmetry ``a`` (-) of the seal.

        For a frictional seal law's slip threshold: ``(1 - a)`` on apply, ``(1 + a)`` on release.
        """
        return 0.0

    def spring_deflection(
        self, seal_displacement: Signal, states: Sequence[Signal]
    ) -> tuple[Signal, list[Signal]]:
        """Effective deflection (m) of the equivalent spring ``k_eh``, and the own states' rates.

        The seals' spring, at the seal displacement ``x_p - x_c`` (m).

        The host applies it only while the spring carries part of the seal force
        (:meth:`spring_share` of the seal-force law below 1).
        """
        del states
        return seal_displacement, []

    def spring_share(self) -> float:
        """Share (-) of the seal force the equivalent spring and damper still carry.

        Under this law's :meth:`seal_force`.
        """
        return 1.0

    def seal_force(self, seal: SealPorts, states: Sequence[Signal]) -> tuple[Signal, list[Signal]]:
        """The seals' force on the piston (N), and the own states' rates.

        Made of the equivalent spring and damper's force, at the seal's state of this instant
        (:class:`SealPorts`); ``states`` are the law's own (SI).
        """
        del states
        return seal.spring_force, []

    def structural_damping(self) -> tuple[float, float]:
        """Damping (N s/m) of the caliper to ground and of the piston to the block."""
        return 0.0, 0.0

    def bore_force(
        self,
        velocity: Signal,
        bore_pressure: Signal,
        caliper_displacement: Signal,
        states: Sequence[Signal],
    ) -> tuple[Signal, list[Signal]]:
        """Force (N) between bore and piston, and the own states' rates.

        The force opposes the seal velocity ``x_p' - x_c'`` (m/s) on the piston and acts on the
        caliper.
        """
        del velocity, caliper_displacement, states
        return 0.0 * bore_pressure, []

    def caliper_share(self, pressure_force: Signal) -> Signal:
        """Share (-) of the pressure force ``A_eb p_b`` (N) that reaches the caliper."""
        del pressure_force
        return 1.0

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        """Channel ``channel`` as its sensor and DAQ pass it on, before noise and quantisation.

        ``channel`` is one of ``p_i``, ``p_b``, ``F_k``, ``x_c``, ``p_a``; ``values`` sampled at
        ``time`` (s).
        """
        del channel, time
        return values

    def internals(self, time: Signal, states: Sequence[Signal]) -> dict[str, Signal]:
        """Signals no sensor sees, by name (SI), at ``time`` (s)."""
        del time, states
        return {}


HOOKS = (
    "drift_factors",
    "specific_compliance",
    "valve_drop",
    "line_flow",
    "seal_asymmetry",
    "spring_deflection",
    "seal_force",
    "structural_damping",
    "bore_force",
    "caliper_share",
    "acquisition",
    "internals",
)
"""Every port's hook, in the order the host evaluates them."""

STATEFUL_HOOKS = ("line_flow", "seal_force", "spring_deflection", "bore_force")
"""Hooks that drive a law's own states, in the order the states are laid out."""

EXCLUSIVE_HOOKS = ("valve_drop", "line_flow", "spring_deflection", "seal_force")
"""Hooks at most one installed law may implement (they replace the host's own law)."""


def implements(law: TruthLaw, hook: str) -> bool:
    """True when ``law`` overrides ``hook`` (the host calls it)."""
    return getattr(type(law), hook) is not getattr(TruthLaw, hook)


def hooked(laws: Sequence[TruthLaw], hook: str) -> tuple[TruthLaw, ...]:
    """The laws that implement ``hook``, in their order."""
    return tuple(law for law in laws if implements(law, hook))


def check_ports(laws: Sequence[TruthLaw], names: Sequence[str]) -> None:
    """Refuse laws the host cannot take together.

    Args:
        laws: the laws in installation order.
        names: the effect each law came from (for the message).

    Raises:
        EffectError: two laws on an exclusive port, or a law with own states and not
            exactly one stateful hook.
    """
    for hook in EXCLUSIVE_HOOKS:
        taken = [name for law, name in zip(laws, names) if implements(law, hook)]
        if len(taken) > 1:
            raise EffectError(f"effects {taken[0]} and {taken[1]} both replace {hook}")
    for law, name in zip(laws, names):
        stateful = [hook for hook in STATEFUL_HOOKS if implements(law, hook)]
        if law.states() and len(stateful) != 1:
            raise EffectError(
                f"effect {name}: a law with own states needs exactly one of "
                f"{', '.join(STATEFUL_HOOKS)} (has {', '.join(stateful) or 'none'})"
            )
