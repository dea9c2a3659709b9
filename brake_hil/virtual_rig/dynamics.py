"""The truth plant's equations (eq. 21 with the installed laws on their ports), for the solver.

:class:`Dynamics` lays out the scaled state vector (the host's states and each law's own),
sorts the installed laws onto the host's ports (:mod:`~brake_hil.virtual_rig.laws`) and
evaluates the derivatives on Python floats (the solver's steps) or on arrays (the Jacobian's
columns, the outputs). :mod:`~brake_hil.virtual_rig.simulator` integrates it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
import math

import numpy as np
from scipy.interpolate import CubicSpline

from brake_hil.physics.lti_model import ModelInput, discretize, state_space
from brake_hil.types import FloatArray
from brake_hil.virtual_rig.excitation import Excitation
from brake_hil.virtual_rig.laws import (
    LineFlow,
    LinePorts,
    SealPorts,
    Signal,
    State,
    TruthLaw,
    hooked,
)
from brake_hil.virtual_rig.plant import Plant

__all__ = ["LOWEST_OPERATING_PRESSURE", "Dynamics", "ProgressCallback"]

LOWEST_OPERATING_PRESSURE = 1.0e3  # Pa, as parameters.effective_bulk_modulus floors it
LOWEST_AIR_PRESSURE = 1.01325e5
"""Pa (one atmosphere): below it (gauge) the instantaneous air law is held at its value here.

Eq. 18's isothermal air modulus is the gauge pressure, singular at 0 Pa; the rig only passes
through such pressures on the first ramp, never while pulsing."""
_JACOBIAN_STEP = 1.5e-8  # relative finite-difference step on the scaled states
_NO_STATES = slice(0, 0)  # a law's own states when it has none

ProgressCallback = Callable[[float], None]
"""Called with the simulated time (s) reached, a few dozen times per run."""


class _Layout:
    """Names, scales and indices of the state vector."""

    def __init__(self) -> None:
        self.names: list[str] = []
        self.scales: list[float] = []

    def add(self, name: str, scale: float) -> int:
        self.names.append(name)
        self.scales.append(scale)
        return len(self.names) - 1

    def extend(self, states: Sequence[State]) -> slice:
        start = len(self.names)
        for state in states:
            self.add(state.name, state.scale)
        return slice(start, len(self.names))


class _Sampled:
    """A signal sampled on a uniform grid, read between samples linearly or by a cubic spline.

    Linear reading is a first-order hold, as the LTI model's discretisation reads its input.
    """

    def __init__(self, time: FloatArray, values: FloatArray, *, cubic: bool = False) -> None:
        self.time = time
        self.values = values
        self.start = float(time[0])
        self.step = float(time[1] - time[0])
        self.last = values.size - 2
        self.constant = bool(np.ptp(values) == 0.0)
        self.spline = CubicSpline(time, values) if cubic and not self.constant else None
        if self.spline is not None:
            self.pieces = self.spline.c.T.tolist()  # per interval: s^3, s^2, s, 1
        else:
            samples = values.tolist()
            self.pieces = [
                [0.0, 0.0, (high - low) / self.step, low]
                for low, high in zip(samples, samples[1:])
            ]

    def __call__(self, t: Signal) -> Signal:
        if self.constant:
            return float(self.values[0]) + 0.0 * t
        if isinstance(t, float):
            position = (t - self.start) / self.step
            index = min(max(int(position), 0), self.last)
            local = t - (self.start + index * self.step)
            cube, square, slope, value = self.pieces[index]
            return ((cube * local + square) * local + slope) * local + value
        if self.spline is not None:
            return self.spline(t)
        return np.interp(t, self.time, self.values)


class _Ports:
    """The installed laws sorted onto the host's ports (see :mod:`~brake_hil.virtual_rig.laws`).

    Each hook is bound once; a port no law implements is None (or empty), and the
    equations then keep eq. 21's own term.
    """

    def __init__(self, laws: Sequence[TruthLaw]) -> None:
        self.drift = [law.drift_factors for law in hooked(laws, "drift_factors")]
        self.more_drift = self.drift[1:]
        compliance = [law.specific_compliance for law in hooked(laws, "specific_compliance")]
        self.extra_compliance: Callable[[Signal], Signal] | None = None
        if len(compliance) == 1:
            self.extra_compliance = compliance[0]
        elif compliance:
            self.extra_compliance = _Summed(compliance)
        valve = hooked(laws, "valve_drop")
        self.valve_drop = (valve[0] if valve else TruthLaw()).valve_drop
        line = hooked(laws, "line_flow")
        self.line = line[0] if line else None
        self.seal_asymmetry = sum((law.seal_asymmetry() for law in laws), 0.0)
        seal = hooked(laws, "seal_force")
        self.seal = seal[0] if seal else None
        spring = hooked(laws, "spring_deflection")
        spring_share = self.seal.spring_share() if self.seal is not None else 1.0
        self.spring = spring[0] if spring and spring_share > 0.0 else None
        self.caliper_damping = 0.0
        self.block_damping = 0.0
        for law in hooked(laws, "structural_damping"):
            caliper, block = law.structural_damping()
            self.caliper_damping += caliper
            self.block_damping += block
        self.bore_forces = hooked(laws, "bore_force")
        self.caliper_share = [law.caliper_share for law in hooked(laws, "caliper_share")]
        self.more_caliper_share = self.caliper_share[1:]
        self.internals = hooked(laws, "internals")

    def stateful(self) -> tuple[list[TruthLaw], list[TruthLaw]]:
        """The laws whose own states the plant integrates, in layout order.

        The line's (before ``p_b``) and the seal's and piston-bore forces' (after ``x_c'``).
        """
        line = [self.line] if self.line is not None else []
        seal = [law for law in (self.seal, self.spring) if law is not None]
        structure = [*seal, *self.bore_forces]
        return [law for law in line if law.states()], [law for law in structure if law.states()]


class _Summed:
    """The sum of several laws' values at one argument, in their order."""

    def __init__(self, hooks: Sequence[Callable[[Signal], Signal]]) -> None:
        self.hooks = hooks

    def __call__(self, value: Signal) -> Signal:
        total = self.hooks[0](value)
        for hook in self.hooks[1:]:
            total = total + hook(value)
        return total


class Dynamics:
    """The truth plant's equations on scaled states: one state (floats) or many (columns)."""

    def __init__(self, plant: Plant, excitation: Excitation, operating: FloatArray) -> None:
        self.plant = plant
        time = np.asarray(excitation.time, dtype=float)
        self.drive = _Sampled(
            time, np.asarray(excitation.pressure, dtype=float), cubic=excitation.air_driven
        )
        self.air_driven = excitation.air_driven
        rig = plant.rig
        fluid = rig.fluid
        # eq. 18 without the walls: fluid and the rig's own (isothermal) air, per unit volume
        self.fluid_compliance = _Sampled(
            time,
            (1.0 - fluid.air_fraction) / fluid.bulk_modulus
            + fluid.air_fraction / np.maximum(operating, LOWEST_OPERATING_PRESSURE),
        )
        # the instantaneous law: liquid per unit volume, and the air at each chamber's pressure
        self.instantaneous_air = plant.rig_air == "instantaneous"
        self.liquid_compliance = (1.0 - fluid.air_fraction) / fluid.bulk_modulus
        self.air_fraction = fluid.air_fraction
        # eq. 18's wall terms, per unit volume
        self.wall_compliance = sum(
            line.diameter / (line.wall * line.youngs_modulus) for line in (rig.hard_pipe, rig.hose)
        )
        overrides = rig.model_overrides
        self.bore_compliance_override = overrides.get("C_b")
        self.master_compliance_override = overrides.get("C_i")
        self.ports = _Ports(plant.laws)

        layout = _Layout()
        if self.air_driven:
            self.i_xi = layout.add("x_i", 1e-4)
            self.i_vi = layout.add("v_i", 1e-2)
            self.i_pi = layout.add("p_i", 1e6)
        self.i_q0 = layout.add("Q_h", 1e-6)
        line_laws, structure_laws = self.ports.stateful()
        own = {id(law): layout.extend(law.states()) for law in line_laws}
        self.i_pb = layout.add("p_b", 1e6)
        self.i_xp = layout.add("x_p", 1e-6)
        self.i_vp = layout.add("v_p", 1e-3)
        self.i_xc = layout.add("x_c", 1e-5)
        self.i_vc = layout.add("v_c", 1e-3)
        own.update({id(law): layout.extend(law.states()) for law in structure_laws})
        # each law's own states as a slice of the state vector (empty when it has none)
        self.own_states = [(law, own[id(law)]) for law in (*line_laws, *structure_laws)]
        ports = self.ports
        self.line_states = own.get(id(ports.line), _NO_STATES)
        self.spring_states = own.get(id(ports.spring), _NO_STATES)
        self.seal_states = own.get(id(ports.seal), _NO_STATES)
        self.bore_forces = [(law, own.get(id(law), _NO_STATES)) for law in ports.bore_forces]
        self.internals = [(law, own.get(id(law), _NO_STATES)) for law in ports.internals]
        self.names = tuple(layout.names)
        self.scale = np.array(layout.scales)
        self.scale_list = layout.scales
        self.size = self.scale.size
        self.line_inertance = plant.pipe_inertance + plant.hose_inertance
        self.progress: ProgressCallback | None = None
        self._next_report = -math.inf
        self._report_every = max(excitation.duration / 50.0, 1e-3)

    def evaluate(
        self, t: Signal, x: Sequence[Signal], *, outputs: bool = False
    ) -> tuple[list[Signal], dict[str, Signal]]:
        """Derivatives (SI, one per state) and, with ``outputs``, the auxiliary signals.

        At time ``t`` (s); without ``outputs`` the auxiliary signals are an empty mapping.

        ``x`` holds the SI states, each a float (and ``t`` a float) or each an array of one
        length (and ``t`` a float or an array of that length).
        """
        params = self.plant.params
        derivative: list[Signal] = [0.0] * self.size
        viscosity, modulus, valve_factor = self._drift(t)
        p_i = self._master_piston(self.drive(t), x, derivative)
        p_b, flow = x[self.i_pb], x[self.i_q0]
        fluid = self._fluid(t, p_b)
        derivative[self.i_q0], derivative[self.line_states], into_bore, bore_extra = self._line(
            p_i, p_b, flow, (viscosity, valve_factor), fluid, x
        )
        if self.air_driven:  # master-cylinder chamber (21b)
            master_fluid = self._fluid(t, p_i)
            master_c = self._chamber(
                self.plant.master_volume,
                self.master_compliance_override,
                p_i,
                master_fluid,
                0.0 * master_fluid,
            )
            derivative[self.i_pi] = (params.master_area * x[self.i_vi] - flow) / master_c
        # seals, piston-bore forces, piston and caliper (21d-f)
        x_p, v_p, x_c, v_c = x[self.i_xp], x[self.i_vp], x[self.i_xc], x[self.i_vc]
        seal_x, seal_v = x_p - x_c, v_p - v_c
        seal_force = self._seal_force(seal_x, seal_v, modulus, viscosity, x, derivative)
        bore_force: Signal = 0.0 * p_b
        for index, (law, own) in enumerate(self.bore_forces):
            force, derivative[own] = law.bore_force(seal_v, p_b, x_c, x[own])
            bore_force = force if index == 0 else bore_force + force
        pressure_force = params.bore_area * p_b
        share = self._caliper_share(pressure_force)
        bore_c = self._chamber(
            self.plant.bore_volume, self.bore_compliance_override, p_b, fluid, bore_extra
        )
        derivative[self.i_pb] = (into_bore - params.piston_area * seal_v) / bore_c
        derivative[self.i_xp] = v_p
        derivative[self.i_vp] = (
            params.piston_area * p_b
            - seal_force
            - bore_force
            - params.block_stiffness * x_p
            - self.ports.block_damping * v_p
        ) / params.piston_mass
        derivative[self.i_xc] = v_c
        derivative[self.i_vc] = (
            -share * pressure_force
            + seal_force
            + bore_force
            - params.caliper_stiffness * x_c
            - self.ports.caliper_damping * v_c
        ) / params.caliper_mass
        if not outputs:
            return derivative, {}
        auxiliary: dict[str, Signal] = {
            "p_i": p_i,
            "p_b": p_b,
            "F_k": params.block_stiffness * x_p,
            "x_c": x_c,
            "seal_displacement": seal_x,
            "seal_force": seal_force,
            "bore_friction_force": bore_force,
            "caliper_force_share": share,
            "bore_compliance": bore_c,
            "line_flow": flow,
        }
        for law, own in self.internals:
            auxiliary.update(law.internals(t, x[own]))
        return derivative, auxiliary

    def _fluid(self, t: Signal, pressure: Signal) -> Signal:
        """Fluid and the rig's own air per unit volume (1/Pa, eq. 18) in a chamber at ``pressure``.

        Linearised: the air isothermal at the operating pressure (a schedule over ``t``).
        Instantaneous: isothermal at ``pressure`` (Pa, gauge, held at
        :data:`LOWEST_AIR_PRESSURE` below it), ``j_a / p``: the air's share of the volume
        stays ``j_a`` and its modulus is the pressure at each instant, so within a pulsing
        cycle the compliance swings by ``1/(1 - a)`` to ``1/(1 + a)`` of the linearised one
        (``a`` the relative pulsing amplitude) while its cycle mean stays within
        ``1/sqrt(1 - a^2) - 1`` of it (4 % at the seed's pulsing).
        """
        if not self.instantaneous_air:
            return self.fluid_compliance(t)
        if isinstance(pressure, float):
            return self.liquid_compliance + self.air_fraction / max(pressure, LOWEST_AIR_PRESSURE)
        floored = np.maximum(pressure, LOWEST_AIR_PRESSURE)
        return self.liquid_compliance + self.air_fraction / floored

    def _drift(self, t: Signal) -> tuple[Signal, Signal, Signal]:
        """The viscosity, seal-modulus and valve factors (-) at ``t``: the laws' product."""
        drift = self.ports.drift
        if not drift:
            return 1.0, 1.0, 1.0
        viscosity, modulus, valve_factor = drift[0](t)
        for more in self.ports.more_drift:
            factors = more(t)
            viscosity = viscosity * factors[0]
            modulus = modulus * factors[1]
            valve_factor = valve_factor * factors[2]
        return viscosity, modulus, valve_factor

    def _master_piston(
        self, drive: Signal, x: Sequence[Signal], derivative: list[Signal]
    ) -> Signal:
        """``p_i`` (Pa): the master piston's (21a, its rates into ``derivative``) or the input."""
        if not self.air_driven:
            return drive
        plant, params = self.plant, self.plant.params
        x_i, v_i, p_i = x[self.i_xi], x[self.i_vi], x[self.i_pi]
        derivative[self.i_xi] = v_i
        derivative[self.i_vi] = (
            params.air_piston_area * drive
            - params.master_area * p_i
            - params.master_spring_stiffness * x_i
            - plant.master_damping * v_i
        ) / params.master_mass
        return p_i

    def _line(
        self,
        p_i: Signal,
        p_b: Signal,
        flow: Signal,
        factors: tuple[Signal, Signal],
        fluid: Signal,
        x: Sequence[Signal],
    ) -> LineFlow:
        """The line (21c): pipe and valve, then the hose, lumped unless a law replaces it.

        Returns what the line port does (:data:`~brake_hil.virtual_rig.laws.LineFlow`);
        ``factors`` are the viscosity's and the valve's drift factors.
        """
        plant, ports = self.plant, self.ports
        viscosity, valve_factor = factors
        valve_drop = ports.valve_drop(flow, plant.valve_resistance, viscosity, valve_factor)
        pipe_drop = plant.pipe_resistance * viscosity * flow + valve_drop
        if ports.line is None:
            hose_drop = plant.hose_resistance * viscosity * flow
            rate = (p_i - p_b - pipe_drop - hose_drop) / self.line_inertance
            return rate, [], flow, 0.0
        line = LinePorts(
            p_i,
            p_b,
            flow,
            pipe_drop,
            plant.hose_resistance * viscosity,
            self.line_inertance,
            fluid,
            ports.extra_compliance,
        )
        return ports.line.line_flow(line, x[self.line_states])

    def _chamber(
        self,
        volume: float,
        override: float | None,
        pressure: Signal,
        fluid: Signal,
        added: Signal,
    ) -> Signal:
        """Compliance (m^3/Pa) of a chamber of ``volume`` (m^3) at ``pressure`` (Pa).

        Eq. 18 (fluid, air and walls) or the rig file's ``override``, plus ``added`` (what the
        line adds) and the laws' extra compliance.
        """
        if override is not None:
            compliance = override + added
        else:
            compliance = volume * (fluid + self.wall_compliance) + added
        extra = self.ports.extra_compliance
        if extra is not None:
            compliance = compliance + volume * extra(pressure)
        return compliance

    def _seal_force(
        self,
        seal_x: Signal,
        seal_v: Signal,
        modulus: Signal,
        viscosity: Signal,
        x: Sequence[Signal],
        derivative: list[Signal],
    ) -> Signal:
        """The seals' force on the piston (N): ``k_eh``, ``c_eh`` or the laws replacing them."""
        ports, params = self.ports, self.plant.params
        spring_x = seal_x
        if ports.spring is not None:
            own = self.spring_states
            spring_x, derivative[own] = ports.spring.spring_deflection(seal_x, x[own])
        seal_force = modulus * (
            params.effective_hydraulic_stiffness * spring_x
            + params.effective_hydraulic_damping * seal_v
        )
        if ports.seal is not None:
            own = self.seal_states
            seal = SealPorts(seal_force, seal_v, ports.seal_asymmetry, modulus, viscosity)
            seal_force, derivative[own] = ports.seal.seal_force(seal, x[own])
        return seal_force

    def _caliper_share(self, pressure_force: Signal) -> Signal:
        """The caliper's share (-) of the pressure force (N): the laws' product."""
        ports = self.ports
        if not ports.caliper_share:
            return 1.0
        share = ports.caliper_share[0](pressure_force)
        for caliper_share in ports.more_caliper_share:
            share = share * caliper_share(pressure_force)
        return share

    def rhs(self, t: float, y: FloatArray) -> FloatArray:
        """``dy/dt`` on scaled states; ``y`` is ``(n,)`` or ``(n, k)`` (vectorised)."""
        if y.ndim == 1:
            if self.progress is not None and t >= self._next_report:
                self.progress(float(t))
                self._next_report = t + self._report_every
            states = [value * scale for value, scale in zip(y.tolist(), self.scale_list)]
            derivative, _ = self.evaluate(float(t), states)
            return np.array([d / scale for d, scale in zip(derivative, self.scale_list)])
        columns = y * self.scale[:, np.newaxis]
        derivative, _ = self.evaluate(float(t), list(columns))
        rows = np.array([np.broadcast_to(d, y.shape[1:]) for d in derivative])
        scaled: FloatArray = rows / self.scale[:, np.newaxis]
        return scaled

    def jacobian(self, t: float, y: FloatArray) -> FloatArray:
        """Forward-difference Jacobian of :meth:`rhs` from one vectorised evaluation."""
        base = self.rhs(t, y)
        steps = _JACOBIAN_STEP * np.maximum(np.abs(y), 1.0)
        perturbed = self.rhs(t, y[:, np.newaxis] + np.diag(steps))
        jacobian: FloatArray = (perturbed - base[:, np.newaxis]) / steps[np.newaxis, :]
        return jacobian

    def signals(self, time: FloatArray, states: FloatArray) -> dict[str, FloatArray]:
        """Auxiliary signals at ``time`` (s) for SI ``states`` of shape ``(n, len(time))``."""
        _, auxiliary = self.evaluate(time, list(states), outputs=True)
        return {
            key: np.array(np.broadcast_to(value, time.shape), dtype=float)
            for key, value in auxiliary.items()
        }

    def initial_state(self, first_input: float) -> FloatArray:
        """Scaled state at rest under the first input sample (the LTI model's equilibrium)."""
        plant = self.plant
        kind = ModelInput.AIR_PRESSURE if self.air_driven else ModelInput.MASTER_CYLINDER_PRESSURE
        system = state_space(plant.params, kind)
        lti = discretize(system).equilibrium(first_input) * system.state_scale
        values = dict(zip(system.state_names, lti.tolist()))
        physical = np.zeros(self.size)
        for index, name in enumerate(self.names):
            if name in values:
                physical[index] = values[name]
        equilibrium = {**values, "seal_displacement": values["x_p"] - values["x_c"]}
        for law, own in self.own_states:
            physical[own] = law.initial_state(equilibrium)
        scaled: FloatArray = physical / self.scale
        return scaled
