"""The virtual rig: the truth plant integrated by a stiff variable-step solver, then the DAQ.

:func:`simulate_rig` integrates the seed's rig end to end, from the air pressure through the
master cylinder (eqs. 21a-b) or from a given master-cylinder pressure, through the line
(21c), the bore chamber (21d), piston (21e) and caliper (21f), with every installed truth law
on the ports it implements (:mod:`brake_hil.virtual_rig.laws`), using
``scipy.integrate.solve_ivp`` (BDF, the variable-order stiff family of MATLAB's ode15s that
the seed used, maximum step 1 ms) on scaled states. The right-hand side runs on Python floats
for the solver's steps and on arrays for the Jacobian (forward differences from one
vectorised call). Between samples the input is read linearly (a first-order hold, as the LTI
discretisation reads it), or by a cubic spline for the air pressure. The true signals are
read at the 1 kHz stamps; the measurement chain then passes each channel through the laws'
acquisition hooks (a delayed channel, a transducer's gain), adds sensor noise and quantises
to 16 bits over the seed's sensor ranges (:mod:`brake_hil.physics.measurement`). Measured
signals are raw (unfiltered).

The nominal compliances follow the seed's eq. 18 with the rig's own air isothermal at the
*operating pressure*: a constant when given, otherwise the moving mean of ``p_i`` over one
excitation period (so each steady segment sits at its own mean pressure, as
:func:`brake_hil.analysis.comparison.compare` derives it). With no effect the equations are
exactly the LTI model's (eq. 21; with the air pressure as input the master piston gets a
small damping, ``master_damping_ratio``, that eq. 21a lacks: without it a ~270 Hz mode rings
undamped).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
import math
from pathlib import Path
import time as wallclock
from typing import NamedTuple

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

from brake_hil.analysis.recording import Recording
from brake_hil.errors import SimulationError
from brake_hil.physics.lti_model import (
    ModelInput,
    air_driven_state_space,
    discretize,
    simulate,
    state_space,
)
from brake_hil.physics.measurement import SENSORS, measure
from brake_hil.physics.parameters import DEFAULT_MEAN_PRESSURE, derive_parameters
from brake_hil.physics.rig import Rig
from brake_hil.types import FloatArray
from brake_hil.virtual_rig.effects.base import Effect
from brake_hil.virtual_rig.excitation import Excitation, seed_pulsing
from brake_hil.virtual_rig.laws import LinePorts, Signal, State, TruthLaw, hooked
from brake_hil.virtual_rig.plant import Plant, build_plant

SOLVER_METHOD = "BDF"
"""Stiff variable-step, variable-order method (ode15s's family)."""
MAX_STEP = 1.0e-3
"""Largest step (s): the seed's setting."""
MASTER_DAMPING_RATIO = 0.2
"""Damping ratio of the master piston in air-driven runs (its seals; not in eq. 21a)."""
RELATIVE_TOLERANCE = 1.0e-4
"""Default relative tolerance."""
ABSOLUTE_TOLERANCE = 1.0e-6
"""Absolute tolerance on the scaled states (1 Pa, 1e-11 m for x_c, 1e-12 m^3/s ...), or
``rtol`` when that is smaller."""
_LOWEST_OPERATING_PRESSURE = 1.0e3  # Pa, as parameters.effective_bulk_modulus floors it
_JACOBIAN_STEP = 1.5e-8  # relative finite-difference step on the scaled states
_NO_STATES = slice(0, 0)  # a law's own states when it has none

ProgressCallback = Callable[[float], None]
"""Called with the simulated time (s) reached, a few dozen times per run."""


class SolverStats(NamedTuple):
    """What the integration cost."""

    method: str
    rtol: float
    max_step: float  # s
    rhs_evaluations: int
    jacobian_evaluations: int
    lu_decompositions: int
    seconds: float  # wall-clock time of the integration


@dataclass(frozen=True, eq=False)
class RigRun:
    """One virtual-rig run at the 1 kHz stamps: true and measured signals (SI).

    The issue-4 rig emulator plays it out in real time from these arrays. ``measured`` holds
    ``p_i``, ``p_b``, ``F_k``, ``x_c`` (and ``p_a`` when air-driven): what the DAQ logs.
    ``internals`` holds signals no sensor sees (seal displacement and force, temperature...).
    """

    time: FloatArray  # s from the first sample
    master_cylinder_pressure: FloatArray  # p_i, Pa (true)
    bore_pressure: FloatArray  # p_b, Pa (true)
    block_force: FloatArray  # F_k, N (true)
    caliper_displacement: FloatArray  # x_c, m (true, negative under load)
    air_pressure: FloatArray | None  # p_a, Pa (true) when the air drives the rig
    measured: Mapping[str, FloatArray]  # by channel key, SI
    internals: Mapping[str, FloatArray]  # by name, SI
    plant: Plant
    excitation: Excitation
    seed: int
    solver: SolverStats
    effects: tuple[Effect, ...] = field(default=())

    def true(self) -> dict[str, FloatArray]:
        """True signals by channel key (``p_i``, ``p_b``, ``F_k``, ``x_c``, and ``p_a``)."""
        signals = {
            "p_i": self.master_cylinder_pressure,
            "p_b": self.bore_pressure,
            "F_k": self.block_force,
            "x_c": self.caliper_displacement,
        }
        if self.air_pressure is not None:
            signals["p_a"] = self.air_pressure
        return signals

    def as_recording(
        self, *, measured: bool = True, path: Path | str = "<virtual rig>"
    ) -> Recording:
        """The run as the readers would return it (measured, or the true signals)."""
        signals = dict(self.measured) if measured else self.true()
        return Recording(
            path=Path(path),
            time=self.time,
            master_cylinder_pressure=signals["p_i"],
            bore_pressure=signals["p_b"],
            block_force=signals["F_k"],
            caliper_displacement=signals["x_c"],
            air_pressure=signals.get("p_a"),
        )


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


def operating_pressure_schedule(
    time: FloatArray, master_pressure: FloatArray, period: float
) -> FloatArray:
    """Moving mean (Pa) of ``master_pressure`` over one excitation ``period`` (s), centred.

    Near the ends the window shrinks to the samples available.
    """
    step = float(np.median(np.diff(time)))
    window = min(max(1, int(round(period / step))), master_pressure.size)
    sums = np.concatenate(([0.0], np.cumsum(master_pressure)))
    index = np.arange(master_pressure.size)
    low = np.clip(index - window // 2, 0, master_pressure.size - window)
    mean: FloatArray = (sums[low + window] - sums[low]) / window
    return mean


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


class _Dynamics:
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
            + fluid.air_fraction / np.maximum(operating, _LOWEST_OPERATING_PRESSURE),
        )
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
        plant, params, ports = self.plant, self.plant.params, self.ports
        derivative: list[Signal] = [0.0] * self.size
        viscosity: Signal = 1.0
        modulus: Signal = 1.0
        valve_factor: Signal = 1.0
        if ports.drift:
            viscosity, modulus, valve_factor = ports.drift[0](t)
            for drift in ports.more_drift:
                factors = drift(t)
                viscosity = viscosity * factors[0]
                modulus = modulus * factors[1]
                valve_factor = valve_factor * factors[2]
        drive = self.drive(t)
        fluid = self.fluid_compliance(t)
        extra = ports.extra_compliance

        # master cylinder (21a) or the given p_i
        if self.air_driven:
            x_i, v_i, p_i = x[self.i_xi], x[self.i_vi], x[self.i_pi]
            derivative[self.i_xi] = v_i
            derivative[self.i_vi] = (
                params.air_piston_area * drive
                - params.master_area * p_i
                - params.master_spring_stiffness * x_i
                - plant.master_damping * v_i
            ) / params.master_mass
        else:
            p_i = drive
        p_b = x[self.i_pb]

        # line (21c): pipe and valve, then the hose (lumped unless a law replaces it)
        flow = x[self.i_q0]
        valve_drop = ports.valve_drop(flow, plant.valve_resistance, viscosity, valve_factor)
        pipe_drop = plant.pipe_resistance * viscosity * flow + valve_drop
        bore_extra: Signal = 0.0
        if ports.line is None:
            hose_drop = plant.hose_resistance * viscosity * flow
            derivative[self.i_q0] = (p_i - p_b - pipe_drop - hose_drop) / self.line_inertance
            into_bore = flow
        else:
            own = self.line_states
            line = LinePorts(
                p_i,
                p_b,
                flow,
                pipe_drop,
                plant.hose_resistance * viscosity,
                self.line_inertance,
                fluid,
                extra,
            )
            derivative[self.i_q0], derivative[own], into_bore, bore_extra = ports.line.line_flow(
                line, x[own]
            )

        # master-cylinder chamber (21b)
        if self.air_driven:
            if self.master_compliance_override is not None:
                master_c = self.master_compliance_override + 0.0 * fluid
            else:
                master_c = plant.master_volume * (fluid + self.wall_compliance)
            if extra is not None:
                master_c = master_c + plant.master_volume * extra(p_i)
            derivative[self.i_pi] = (params.master_area * v_i - flow) / master_c

        # seals, piston-bore forces, piston and caliper (21d-f)
        x_p, v_p, x_c, v_c = x[self.i_xp], x[self.i_vp], x[self.i_xc], x[self.i_vc]
        seal_x, seal_v = x_p - x_c, v_p - v_c
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
            seal_force, derivative[own] = ports.seal.seal_force(
                seal_force, seal_v, ports.seal_asymmetry, modulus, viscosity, x[own]
            )
        bore_force: Signal = 0.0 * p_b
        for index, (law, own) in enumerate(self.bore_forces):
            force, derivative[own] = law.bore_force(seal_v, p_b, x_c, x[own])
            bore_force = force if index == 0 else bore_force + force
        pressure_force = params.bore_area * p_b
        share: Signal = 1.0
        if ports.caliper_share:
            share = ports.caliper_share[0](pressure_force)
            for caliper_share in ports.more_caliper_share:
                share = share * caliper_share(pressure_force)

        if self.bore_compliance_override is not None:
            bore_c = self.bore_compliance_override + bore_extra
        else:
            bore_c = plant.bore_volume * (fluid + self.wall_compliance) + bore_extra
        if extra is not None:
            bore_c = bore_c + plant.bore_volume * extra(p_b)
        derivative[self.i_pb] = (into_bore - params.piston_area * seal_v) / bore_c
        derivative[self.i_xp] = v_p
        derivative[self.i_vp] = (
            params.piston_area * p_b
            - seal_force
            - bore_force
            - params.block_stiffness * x_p
            - ports.block_damping * v_p
        ) / params.piston_mass
        derivative[self.i_xc] = v_c
        derivative[self.i_vc] = (
            -share * pressure_force
            + seal_force
            + bore_force
            - params.caliper_stiffness * x_c
            - ports.caliper_damping * v_c
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


def master_pressure_estimate(rig: Rig, excitation: Excitation) -> FloatArray:
    """``p_i`` (Pa) of the run: the input itself, or the LTI model's answer to ``p_a``."""
    if not excitation.air_driven:
        return np.asarray(excitation.pressure, dtype=float)
    master = rig.master_cylinder
    gain = (master.diameter / master.air_piston_diameter) ** 2
    guess = max(float(np.mean(excitation.pressure)) / gain, DEFAULT_MEAN_PRESSURE / 10.0)
    system = air_driven_state_space(derive_parameters(rig, guess))
    estimate: FloatArray = simulate(discretize(system), excitation.pressure)[3]
    return estimate


def acquire(
    time: FloatArray,
    true_signals: Mapping[str, FloatArray],
    laws: Sequence[TruthLaw] = (),
    seed: int = 0,
) -> dict[str, FloatArray]:
    """The DAQ: each law's acquisition hook on every channel, then noise and quantisation.

    The hooks run in the laws' order (a delayed channel, a transducer's gain); quantisation is
    16 bits over the seed's ranges.

    Channels are drawn in the order ``p_i``, ``p_b``, ``F_k``, ``x_c``, ``p_a`` from one
    generator seeded with ``seed``, so a law on one channel leaves the others' noise unchanged.
    """
    chain = hooked(laws, "acquisition")
    rng = np.random.default_rng(seed)
    measured: dict[str, FloatArray] = {}
    for key in ("p_i", "p_b", "F_k", "x_c", "p_a"):
        if key not in true_signals:
            continue
        values = np.asarray(true_signals[key], dtype=float)
        for law in chain:
            values = law.acquisition(key, time, values)
        measured[key] = measure(values, SENSORS[key], rng)
    return measured


def simulate_rig(
    truth_rig: Rig,
    effects: Sequence[Effect] = (),
    excitation: Excitation | None = None,
    *,
    operating_pressure: float | None = None,
    master_damping_ratio: float = MASTER_DAMPING_RATIO,
    seed: int = 0,
    rtol: float = RELATIVE_TOLERANCE,
    max_step: float = MAX_STEP,
    method: str = SOLVER_METHOD,
    progress: ProgressCallback | None = None,
) -> RigRun:
    """Run the virtual rig: the truth rig with ``effects`` driven by ``excitation``.

    Args:
        truth_rig: the rig as it really is (not what the test engineer believes).
        effects: the physics the LTI model leaves out, each at its strength; none gives the
            LTI model's answer (to the solver's tolerance).
        excitation: the input; default :func:`~brake_hil.virtual_rig.excitation.seed_pulsing`.
        operating_pressure: the mean master-cylinder pressure (Pa) at which the rig's own
            air is isothermal (eq. 18); ``None`` follows the moving mean of ``p_i`` over one
            excitation period.
        master_damping_ratio: damping ratio of the master piston (air-driven runs); eq. 21a
            has none, which leaves a ~270 Hz mode undamped. 0 reproduces eq. 21a exactly.
        seed: seed of the sensor noise.
        rtol: relative tolerance; the absolute tolerance is ``min(rtol, 1e-6)`` on the
            scaled states (Pa / 1e6, m / 1e-5, ...).
        max_step: largest solver step (s); the seed's 1 ms by default.
        method: ``"BDF"`` or ``"Radau"`` (stiff, implicit).
        progress: called with the simulated time (s) now and then (a progress bar).

    Returns:
        The run at the excitation's stamps.

    Raises:
        EffectError: an effect named twice, or an effect the rig cannot take.
        SimulationError: the solver failed.
    """
    excitation = excitation if excitation is not None else seed_pulsing()
    time = np.asarray(excitation.time, dtype=float)
    period = 1.0 / truth_rig.excitation_hz
    if operating_pressure is None:
        schedule = operating_pressure_schedule(
            time, master_pressure_estimate(truth_rig, excitation), period
        )
        mean_pressure = float(np.mean(schedule))
    else:
        schedule = np.full(time.size, float(operating_pressure))
        mean_pressure = float(operating_pressure)
    plant = build_plant(
        truth_rig,
        effects,
        max(mean_pressure, _LOWEST_OPERATING_PRESSURE),
        master_damping_ratio if excitation.air_driven else 0.0,
    )
    dynamics = _Dynamics(plant, excitation, schedule)
    start = dynamics.initial_state(float(excitation.pressure[0]))
    dynamics.progress = progress
    began = wallclock.perf_counter()
    solution = solve_ivp(
        dynamics.rhs,
        (float(time[0]), float(time[-1])),
        start,
        method=method,
        t_eval=time,
        rtol=rtol,
        atol=min(rtol, ABSOLUTE_TOLERANCE),
        max_step=max_step,
        jac=dynamics.jacobian,
    )
    seconds = wallclock.perf_counter() - began
    if not solution.success or solution.y.shape[1] != time.size:
        reached = float(solution.t[-1]) if solution.t.size else float(time[0])
        raise SimulationError(
            f"virtual rig ({truth_rig.source}): the {method} solver stopped at {reached:.4f} s "
            f"of {time[-1]:.3f} s: {solution.message}"
        )
    if progress is not None:
        progress(float(time[-1]))
    auxiliary = dynamics.signals(time, solution.y * dynamics.scale[:, np.newaxis])
    true_signals = {
        key: np.array(auxiliary[key], dtype=float) for key in ("p_i", "p_b", "F_k", "x_c")
    }
    if excitation.air_driven:
        true_signals["p_a"] = np.array(excitation.pressure, dtype=float)
    internals = {key: value for key, value in auxiliary.items() if key not in true_signals}
    internals["operating_pressure"] = schedule
    stats = SolverStats(
        method=method,
        rtol=rtol,
        max_step=max_step,
        rhs_evaluations=int(solution.nfev),
        jacobian_evaluations=int(solution.njev),
        lu_decompositions=int(solution.nlu),
        seconds=seconds,
    )
    return RigRun(
        time=time,
        master_cylinder_pressure=true_signals["p_i"],
        bore_pressure=true_signals["p_b"],
        block_force=true_signals["F_k"],
        caliper_displacement=true_signals["x_c"],
        air_pressure=true_signals.get("p_a"),
        measured=acquire(time, true_signals, plant.laws, seed),
        internals=internals,
        plant=plant,
        excitation=excitation,
        seed=seed,
        solver=stats,
        effects=plant.effects,
    )
