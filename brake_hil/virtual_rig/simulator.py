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

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
import time as wallclock
from typing import NamedTuple

import numpy as np
from scipy.integrate import solve_ivp

from brake_hil.analysis.recording import Recording
from brake_hil.errors import SimulationError
from brake_hil.physics.lti_model import (
    air_driven_state_space,
    discretize,
    simulate,
)
from brake_hil.physics.measurement import SENSORS, measure
from brake_hil.physics.parameters import DEFAULT_MEAN_PRESSURE, derive_parameters
from brake_hil.physics.rig import Rig
from brake_hil.types import FloatArray
from brake_hil.virtual_rig.dynamics import LOWEST_OPERATING_PRESSURE, Dynamics, ProgressCallback
from brake_hil.virtual_rig.effects.base import Effect
from brake_hil.virtual_rig.excitation import Excitation, seed_pulsing
from brake_hil.virtual_rig.laws import TruthLaw, hooked
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

    The rig emulator plays it out in real time from these arrays. ``measured`` holds
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
    rig_air: str = "linearised",
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
        operating_pressure: mean ``p_i`` (Pa) at which the linearised air is isothermal
            (eq. 18); ``None``: the moving mean of ``p_i`` over one excitation period.
        master_damping_ratio: damping ratio of the master piston (air-driven runs); eq. 21a
            has none, which leaves a ~270 Hz mode undamped. 0 reproduces eq. 21a exactly.
        rig_air: the rig's own air (``plant.RIG_AIR_LAWS``): ``linearised`` at the operating
            pressure (eq. 18), or ``instantaneous``, at each chamber's pressure (a real rig's).
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
    schedule, mean_pressure = _operating_pressure(truth_rig, excitation, operating_pressure)
    plant = build_plant(
        truth_rig,
        effects,
        max(mean_pressure, LOWEST_OPERATING_PRESSURE),
        master_damping_ratio if excitation.air_driven else 0.0,
        rig_air,
    )
    dynamics = Dynamics(plant, excitation, schedule)
    dynamics.progress = progress
    solver = SolverStats(method, rtol, max_step, 0, 0, 0, 0.0)
    states, stats = _integrate(dynamics, excitation, solver, truth_rig.source)
    if progress is not None:
        progress(float(time[-1]))
    auxiliary = dynamics.signals(time, states)
    true_signals = {
        key: np.array(auxiliary[key], dtype=float) for key in ("p_i", "p_b", "F_k", "x_c")
    }
    if excitation.air_driven:
        true_signals["p_a"] = np.array(excitation.pressure, dtype=float)
    internals = {key: value for key, value in auxiliary.items() if key not in true_signals}
    internals["operating_pressure"] = schedule
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


def _operating_pressure(
    rig: Rig, excitation: Excitation, operating_pressure: float | None
) -> tuple[FloatArray, float]:
    """The operating pressure (Pa) at each stamp, and its mean (see :func:`simulate_rig`)."""
    time = np.asarray(excitation.time, dtype=float)
    if operating_pressure is None:
        period = 1.0 / rig.excitation_hz
        schedule = operating_pressure_schedule(
            time, master_pressure_estimate(rig, excitation), period
        )
        return schedule, float(np.mean(schedule))
    return np.full(time.size, float(operating_pressure)), float(operating_pressure)


def _integrate(
    dynamics: Dynamics, excitation: Excitation, solver: SolverStats, source: str
) -> tuple[FloatArray, SolverStats]:
    """The SI states at the excitation's stamps, from rest, and what the integration cost.

    ``solver`` gives the method, ``rtol`` and the largest step (its counts are ignored).

    Raises:
        SimulationError: the solver failed (``source`` names the rig in the message).
    """
    time = np.asarray(excitation.time, dtype=float)
    start = dynamics.initial_state(float(excitation.pressure[0]))
    began = wallclock.perf_counter()
    solution = solve_ivp(
        dynamics.rhs,
        (float(time[0]), float(time[-1])),
        start,
        method=solver.method,
        t_eval=time,
        rtol=solver.rtol,
        atol=min(solver.rtol, ABSOLUTE_TOLERANCE),
        max_step=solver.max_step,
        jac=dynamics.jacobian,
    )
    seconds = wallclock.perf_counter() - began
    if not solution.success or solution.y.shape[1] != time.size:
        reached = float(solution.t[-1]) if solution.t.size else float(time[0])
        raise SimulationError(
            f"virtual rig ({source}): the {solver.method} solver stopped at {reached:.4f} s "
            f"of {time[-1]:.3f} s: {solution.message}"
        )
    stats = solver._replace(
        rhs_evaluations=int(solution.nfev),
        jacobian_evaluations=int(solution.njev),
        lu_decompositions=int(solution.nlu),
        seconds=seconds,
    )
    states: FloatArray = solution.y * dynamics.scale[:, np.newaxis]
    return states, stats
