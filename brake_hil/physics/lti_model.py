"""The seed's linear time-invariant caliper model (Liette et al. 2012, eq. 21).

With the master-cylinder pressure ``p_i`` as input (eqs. 21c-f) the state is
``[Q_h, p_b, x_p, x_p', x_c, x_c']``::

    (I_r + I_t) Q_h' = p_i - p_b - (R_r + R_v + R_t) Q_h                     (21c)
    C_b p_b'         = Q_h - A_ep (x_p' - x_c')                              (21d)
    M_p x_p''        = A_ep p_b - c_eh (x_p' - x_c') - k_eh (x_p - x_c) - k_k x_p   (21e)
    M_c x_c''        = -A_eb p_b - c_eh (x_c' - x_p') - k_eh (x_c - x_p) - k_c x_c  (21f)

and the outputs are ``p_b``, ``F_k = k_k x_p`` and ``x_c``. With the air pressure ``p_a`` as
input (eqs. 21a-b) the state grows by ``[x_i, x_i', p_i]`` in front::

    M_i x_i'' + k_i x_i = A_a p_a - A_i p_i                                  (21a)
    C_i p_i'            = -Q_h + A_i x_i'                                    (21b)

and ``p_i`` becomes a fourth output. The system is stiff (eigenvalues from ~17 Hz to ~170 kHz
with the default rig), so it is discretised exactly: a first-order hold (the input is linear
between samples, as a 1 kHz sampled signal is best read) through the matrix exponential.
That gives the per-sample :class:`CaliperStepper` for the real-time node and the vectorised
:func:`simulate` for whole recordings; both produce the same numbers.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import NamedTuple

import numpy as np
import scipy.linalg
import scipy.signal

from brake_hil.physics.parameters import ModelParameters
from brake_hil.types import FloatArray

SAMPLE_TIME = 1.0e-3
"""Nominal sample time of recordings and the real-time loop (s)."""


class ModelInput(Enum):
    """Which pressure drives the model."""

    MASTER_CYLINDER_PRESSURE = "p_i"  # eqs. 21c-f
    AIR_PRESSURE = "p_a"  # eqs. 21a-f


class StateSpace(NamedTuple):
    """Continuous-time ``x' = A x + B u``, ``y = C x`` in SI units."""

    state_matrix: FloatArray  # A
    input_matrix: FloatArray  # B, column (n, 1)
    output_matrix: FloatArray  # C
    state_names: tuple[str, ...]
    output_names: tuple[str, ...]
    state_scale: FloatArray  # typical magnitude of each state (SI), for conditioning


CALIPER_STATES = ("Q_h", "p_b", "x_p", "v_p", "x_c", "v_c")
CALIPER_SCALE = (1e-6, 1e6, 1e-6, 1e-3, 1e-5, 1e-3)
MASTER_STATES = ("x_i", "v_i", "p_i")
MASTER_SCALE = (1e-4, 1e-2, 1e6)
PRESSURE_SCALE = 1e6
"""Input scaling (Pa) used inside the discretisation."""


def caliper_state_space(params: ModelParameters) -> StateSpace:
    """Eqs. 21c-f with ``p_i`` as input; outputs ``p_b``, ``F_k``, ``x_c``."""
    p = params
    A = np.zeros((6, 6))
    B = np.zeros((6, 1))
    q, pb, xp, vp, xc, vc = range(6)
    A[q, q] = -p.line_resistance / p.line_inertance
    A[q, pb] = -1.0 / p.line_inertance
    B[q, 0] = 1.0 / p.line_inertance
    A[pb, q] = 1.0 / p.bore_compliance
    A[pb, vp] = -p.piston_area / p.bore_compliance
    A[pb, vc] = p.piston_area / p.bore_compliance
    A[xp, vp] = 1.0
    k, c = p.effective_hydraulic_stiffness, p.effective_hydraulic_damping
    A[vp, pb] = p.piston_area / p.piston_mass
    A[vp, xp] = -(k + p.block_stiffness) / p.piston_mass
    A[vp, xc] = k / p.piston_mass
    A[vp, vp] = -c / p.piston_mass
    A[vp, vc] = c / p.piston_mass
    A[xc, vc] = 1.0
    A[vc, pb] = -p.bore_area / p.caliper_mass
    A[vc, xc] = -(k + p.caliper_stiffness) / p.caliper_mass
    A[vc, xp] = k / p.caliper_mass
    A[vc, vc] = -c / p.caliper_mass
    A[vc, vp] = c / p.caliper_mass
    C = np.zeros((3, 6))
    C[0, pb] = 1.0
    C[1, xp] = p.block_stiffness
    C[2, xc] = 1.0
    return StateSpace(A, B, C, CALIPER_STATES, ("p_b", "F_k", "x_c"), np.array(CALIPER_SCALE))


def air_driven_state_space(params: ModelParameters) -> StateSpace:
    """Eqs. 21a-f with the air pressure ``p_a`` as input; outputs ``p_b, F_k, x_c, p_i``."""
    p = params
    caliper = caliper_state_space(params)
    A = np.zeros((9, 9))
    B = np.zeros((9, 1))
    xi, vi, pi = 0, 1, 2
    A[3:, 3:] = caliper.state_matrix
    A[3:, pi] = caliper.input_matrix[:, 0]  # p_i drives the line (21c)
    A[xi, vi] = 1.0
    A[vi, xi] = -p.master_spring_stiffness / p.master_mass
    A[vi, pi] = -p.master_area / p.master_mass
    B[vi, 0] = p.air_piston_area / p.master_mass
    A[pi, 3] = -1.0 / p.master_compliance  # -Q_h / C_i (21b)
    A[pi, vi] = p.master_area / p.master_compliance
    C = np.zeros((4, 9))
    C[:3, 3:] = caliper.output_matrix
    C[3, pi] = 1.0
    return StateSpace(
        A,
        B,
        C,
        MASTER_STATES + CALIPER_STATES,
        ("p_b", "F_k", "x_c", "p_i"),
        np.array(MASTER_SCALE + CALIPER_SCALE),
    )


def state_space(params: ModelParameters, model_input: ModelInput) -> StateSpace:
    """The continuous model for the chosen input."""
    if model_input is ModelInput.AIR_PRESSURE:
        return air_driven_state_space(params)
    return caliper_state_space(params)


@dataclass(frozen=True)
class DiscreteModel:
    """Exact first-order-hold discretisation of a StateSpace (scaled states).

    ``z[k+1] = transition z[k] + input_previous u[k] + input_current u[k+1]``,
    ``y[k] = output_matrix z[k]``, with ``u`` in Pa and ``z`` scaled by ``state_scale``.
    """

    transition: FloatArray
    input_previous: FloatArray  # (n,)
    input_current: FloatArray  # (n,)
    output_matrix: FloatArray  # (m, n), gives SI outputs
    equilibrium_gain: FloatArray  # (n,), z per Pa of constant input
    sample_time: float
    output_names: tuple[str, ...]

    @property
    def order(self) -> int:
        """Number of states."""
        return int(self.transition.shape[0])

    def equilibrium(self, pressure: float) -> FloatArray:
        """Scaled steady state under a constant input ``pressure`` (Pa)."""
        return self.equilibrium_gain * pressure


def discretize(system: StateSpace, sample_time: float = SAMPLE_TIME) -> DiscreteModel:
    """First-order-hold discretisation by one matrix exponential.

    Exact for piecewise-linear input. States are scaled to order one first so the stiff system
    stays well conditioned.
    """
    scale = system.state_scale
    A = system.state_matrix * scale[np.newaxis, :] / scale[:, np.newaxis]
    B = system.input_matrix[:, 0] / scale
    n = A.shape[0]
    # expm([[A, B, 0], [0, 0, 1/h], [0, 0, 0]] h) = [[Phi, G1, G2], [0, 1, 1], [0, 0, 1]]
    block = np.zeros((n + 2, n + 2))
    block[:n, :n] = A * sample_time
    block[:n, n] = B * sample_time
    block[n, n + 1] = 1.0
    exponential = scipy.linalg.expm(block)
    transition = exponential[:n, :n]
    gamma_1 = exponential[:n, n]
    gamma_2 = exponential[:n, n + 1]
    equilibrium_gain = _equilibrium_gain(A, B)
    return DiscreteModel(
        transition=transition,
        input_previous=gamma_1 - gamma_2,
        input_current=gamma_2,
        output_matrix=system.output_matrix * scale[np.newaxis, :],
        equilibrium_gain=equilibrium_gain,
        sample_time=sample_time,
        output_names=system.output_names,
    )


def _equilibrium_gain(A: FloatArray, B: FloatArray) -> FloatArray:
    """Steady state per unit input, ``A x = -B``.

    With the air-pressure input the hydraulic circuit is closed: the fluid volume
    ``C_i p_i + C_b p_b + A_ep (x_p - x_c) - A_i x_i`` is conserved, so ``A`` is singular.
    The equilibrium is then the one that keeps that conserved quantity at its value in the
    unloaded state (zero), i.e. the least-squares solution orthogonal to the null space.
    """
    singular_values = np.linalg.svd(A, compute_uv=False)
    if singular_values[-1] > 1e-12 * singular_values[0]:
        return np.asarray(-np.linalg.solve(A, B))
    conserved = np.linalg.svd(A.T)[2][-1]  # left null vector: the conserved combination
    system = np.vstack([A, conserved])
    target = np.concatenate([-B, [0.0]])
    solution, *_ = np.linalg.lstsq(system, target, rcond=None)
    return np.asarray(solution)


class ModelOutput(NamedTuple):
    """One prediction of the caliper model (SI)."""

    bore_pressure: float  # p_b, Pa
    block_force: float  # F_k, N
    caliper_displacement: float  # x_c, m


class CaliperStepper:
    """Per-sample stepping of a DiscreteModel for the real-time node.

    The first call starts from the equilibrium at that input (as :func:`simulate` does), so a
    live run and the offline batch agree sample for sample.
    """

    def __init__(self, model: DiscreteModel) -> None:
        self._model = model
        self._transition = model.transition
        self._input_previous = model.input_previous
        self._input_current = model.input_current
        self._output = model.output_matrix[:3]
        self._state: FloatArray | None = None
        self._previous_input = 0.0

    @property
    def started(self) -> bool:
        """True once the first input has set the initial equilibrium."""
        return self._state is not None

    def reset(self) -> None:
        """Forget the state; the next step starts again from equilibrium."""
        self._state = None

    def step(self, pressure: float) -> ModelOutput:
        """Advance one sample with the new input ``pressure`` (Pa); return the outputs."""
        if self._state is None:
            state = self._model.equilibrium(pressure)
        else:
            state = (
                self._transition @ self._state
                + self._input_previous * self._previous_input
                + self._input_current * pressure
            )
        self._state = state
        self._previous_input = pressure
        p_b, f_k, x_c = (self._output @ state).tolist()
        return ModelOutput(p_b, f_k, x_c)


def simulate(model: DiscreteModel, pressure: FloatArray) -> FloatArray:
    """Outputs (m, N) of the model driven by the sampled input ``pressure`` (Pa, N samples).

    Starts from equilibrium at ``pressure[0]``. Vectorised by a modal decomposition of the
    transition matrix: each mode is a first-order recursion run by ``scipy.signal.lfilter``.
    Falls back to a plain loop when the eigenvectors are ill-conditioned.
    """
    u = np.asarray(pressure, dtype=float)
    if u.ndim != 1 or u.size == 0:
        raise ValueError(f"pressure must be a non-empty 1-D array, got shape {u.shape}")
    eigenvalues, vectors = np.linalg.eig(model.transition)
    if np.linalg.cond(vectors) > 1e8:
        return _simulate_loop(model, u)
    inverse = np.linalg.inv(vectors)
    gain_previous = inverse @ model.input_previous
    gain_current = inverse @ model.input_current
    modal_start = inverse @ model.equilibrium(u[0])
    modes = np.empty((model.order, u.size), dtype=complex)
    for j, lam in enumerate(eigenvalues):
        initial = gain_previous[j] * u[0] + lam * modal_start[j]
        modes[j], _ = scipy.signal.lfilter(
            [gain_current[j], gain_previous[j]], [1.0, -lam], u, zi=[initial]
        )
    return np.real((model.output_matrix @ vectors) @ modes)


def _simulate_loop(model: DiscreteModel, u: FloatArray) -> FloatArray:
    states = np.empty((u.size, model.order))
    state = model.equilibrium(u[0])
    states[0] = state
    for k in range(1, u.size):
        state = (
            model.transition @ state + model.input_previous * u[k - 1] + model.input_current * u[k]
        )
        states[k] = state
    return np.asarray(model.output_matrix @ states.T)


def eigenfrequencies(system: StateSpace) -> FloatArray:
    """Magnitudes of the continuous eigenvalues in Hz, ascending (stiffness check)."""
    return np.sort(np.abs(np.linalg.eigvals(system.state_matrix))) / (2.0 * np.pi)
