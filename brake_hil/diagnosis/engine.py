"""Simulator of the diagnosis's candidate models: the LTI caliper model plus left-out physics.

The diagnosis fits many candidate models, each many times, so this simulator runs a *batch*
of parameter sets in one pass (one pass gives a whole finite-difference Jacobian):

* The linear part (eq. 21c-f, optionally with an extra hose node) is discretised exactly with
  a first-order hold on ``p_i``, as :mod:`brake_hil.physics.lti_model` does.
* One Jenkins element (spring ``k_j`` and Coulomb slider) may act between piston and caliper,
  in parallel with the equivalent seal spring and damper: its slip threshold is a constant
  per direction (seal friction; apply and release differ with groove asymmetry) plus a term
  ``mu p_b |x_c|`` (piston-bore friction from caliper cocking, seed eq. 8). The element
  switches between two exactly discretised linear systems, *stuck* (spring present, offset
  held) and *slipping* (spring absent, the friction force an input held over the step), so a
  stiff stuck seal is integrated exactly and slip adds no artificial damping.
* Other nonlinear terms are inputs held over one step (exponential integrator): a quadratic
  orifice drop ``K Q |Q|`` on top of the linear line resistance, and the load-dependent part of
  the caliper's share of the pressure force.
* Terms that change the stiff linear part itself are scheduled: the transition matrices are
  tabulated over a grid of bore pressure (compliance of entrained air) and of time blocks
  (drift of viscosity and seal terms with temperature); each step takes its entry.

A candidate of :mod:`brake_hil.diagnosis.candidates` only fills a :class:`ModelSpec`;
this module knows no effect names.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from brake_hil.physics.lti_model import DiscreteModel, simulate
from brake_hil.physics.parameters import ModelParameters
from brake_hil.types import FloatArray

REFERENCE_PRESSURE = 1.0e6
"""Pressure (Pa) about which load-dependent terms are written."""
ATMOSPHERE = 1.013e5
"""Absolute pressure of gauge zero (Pa)."""
STATE_SCALE = {
    "Q_p": 1e-6,
    "p_h": 1e6,
    "Q_h": 1e-6,
    "p_b": 1e6,
    "x_p": 1e-6,
    "v_p": 1e-3,
    "x_c": 1e-5,
    "v_c": 1e-3,
}

# Explicit-input columns of the linear plant.
RELATIVE_FORCE, CALIPER_FORCE, LINE_DROP = range(3)
INPUTS = 3
HOSE_INERTANCE_SHARE = 0.3
"""Part of the line inertance beyond the hose node (the seed rig's 0.6 m hose of 2.1 m)."""
STUCK, SLIPPING = 0, 1
APPLY, RELEASE = 0, 1


@dataclass(frozen=True)
class ModelSpec:
    """One candidate model for a batch of ``B`` parameter sets (arrays of length ``B``).

    Every optional field left ``None`` keeps the LTI model of ``params``.
    """

    params: tuple[ModelParameters, ...]  # coefficients per set (calibrated LTI, adjusted)
    jenkins_spring: FloatArray | None = None  # N/m, k_j of the friction element
    apply_threshold: FloatArray | None = None  # N, slip force while x_p - x_c grows
    release_threshold: FloatArray | None = None  # N, slip force while it shrinks
    bore_friction: FloatArray | None = None  # N/(Pa m), extra threshold per p_b |x_c|
    orifice_coefficient: FloatArray | None = None  # Pa s^2/m^6, dp = K Q |Q|
    hose_compliance: FloatArray | None = None  # m^3/Pa, node between pipe and hose
    hose_resistance_share: FloatArray | None = None  # -, part of R beyond the hose node
    share_slope: FloatArray | None = None  # -, share s = s0 + s1 (p_b - p_ref) / p_ref
    air_volume: FloatArray | None = None  # m^3, isothermal air volume at gauge zero
    drift_rate: FloatArray | None = None  # 1/s, relative drift of the line resistance
    seal_drift_rate: FloatArray | None = None  # 1/s, relative drift of k_eh and c_eh
    drift_reference: FloatArray | None = None  # s, recording time at which drift is zero
    output_delay: FloatArray | None = None  # (B, 3) s, acquisition delay per channel
    stiffness_asymmetry: FloatArray | None = None  # -, k_eh (1 - a) apply side, (1 + a) release
    relaxation_time: FloatArray | None = None  # s, creep of the seal's relaxed position

    @property
    def batch(self) -> int:
        """Number of parameter sets."""
        return len(self.params)

    @property
    def is_linear(self) -> bool:
        """True when only linear terms are set (the fast modal path applies)."""
        nonlinear = (
            self.jenkins_spring,
            self.orifice_coefficient,
            self.share_slope,
            self.air_volume,
            self.drift_rate,
            self.stiffness_asymmetry,
        )
        return all(term is None for term in nonlinear)

    @property
    def has_jenkins(self) -> bool:
        """True when a friction element acts between piston and caliper."""
        return self.jenkins_spring is not None


@dataclass(frozen=True)
class _Plant:
    A: FloatArray  # (n, n), scaled states
    B: FloatArray  # (n,) p_i input
    W: FloatArray  # (n, INPUTS) explicit inputs
    C: FloatArray  # (3, n) SI outputs from scaled states
    scale: FloatArray  # (n,)
    index: dict[str, int]


def _plant(
    p: ModelParameters,
    *,
    relative_stiffness: float,
    relative_damping: float,
    line_resistance: float,
    bore_compliance: float,
    hose_compliance: float | None,
    hose_resistance_share: float = 0.3,
) -> _Plant:
    """Scaled continuous plant of eq. 21c-f with the given piston-caliper coupling."""
    names = ["Q_h", "p_b", "x_p", "v_p", "x_c", "v_c"]
    if hose_compliance is not None:
        names = ["Q_p", "p_h", *names]
    n = len(names)
    i = {name: k for k, name in enumerate(names)}
    A = np.zeros((n, n))
    B = np.zeros(n)
    W = np.zeros((n, INPUTS))
    if hose_compliance is None:
        A[i["Q_h"], i["Q_h"]] = -line_resistance / p.line_inertance
        A[i["Q_h"], i["p_b"]] = -1.0 / p.line_inertance
        B[i["Q_h"]] = 1.0 / p.line_inertance
        W[i["Q_h"], LINE_DROP] = -1.0 / p.line_inertance
    else:  # pipe and valve up to the node, the hose beyond it
        r_share, i_share = hose_resistance_share, HOSE_INERTANCE_SHARE
        r_pipe, r_hose = (1 - r_share) * line_resistance, r_share * line_resistance
        i_pipe, i_hose = (1 - i_share) * p.line_inertance, i_share * p.line_inertance
        A[i["Q_p"], i["Q_p"]] = -r_pipe / i_pipe
        A[i["Q_p"], i["p_h"]] = -1.0 / i_pipe
        B[i["Q_p"]] = 1.0 / i_pipe
        W[i["Q_p"], LINE_DROP] = -1.0 / i_pipe
        A[i["p_h"], i["Q_p"]] = 1.0 / hose_compliance
        A[i["p_h"], i["Q_h"]] = -1.0 / hose_compliance
        A[i["Q_h"], i["p_h"]] = 1.0 / i_hose
        A[i["Q_h"], i["Q_h"]] = -r_hose / i_hose
        A[i["Q_h"], i["p_b"]] = -1.0 / i_hose
    A[i["p_b"], i["Q_h"]] = 1.0 / bore_compliance
    A[i["p_b"], i["v_p"]] = -p.piston_area / bore_compliance
    A[i["p_b"], i["v_c"]] = p.piston_area / bore_compliance
    k, c = relative_stiffness, relative_damping
    A[i["x_p"], i["v_p"]] = 1.0
    A[i["v_p"], i["p_b"]] = p.piston_area / p.piston_mass
    A[i["v_p"], i["x_p"]] = -(k + p.block_stiffness) / p.piston_mass
    A[i["v_p"], i["x_c"]] = k / p.piston_mass
    A[i["v_p"], i["v_p"]] = -c / p.piston_mass
    A[i["v_p"], i["v_c"]] = c / p.piston_mass
    A[i["x_c"], i["v_c"]] = 1.0
    A[i["v_c"], i["p_b"]] = -p.bore_area / p.caliper_mass
    A[i["v_c"], i["x_c"]] = -(k + p.caliper_stiffness) / p.caliper_mass
    A[i["v_c"], i["x_p"]] = k / p.caliper_mass
    A[i["v_c"], i["v_c"]] = -c / p.caliper_mass
    A[i["v_c"], i["v_p"]] = c / p.caliper_mass
    W[i["v_p"], RELATIVE_FORCE] = 1.0 / p.piston_mass  # + on the piston ...
    W[i["v_c"], RELATIVE_FORCE] = -1.0 / p.caliper_mass  # ... and - on the caliper
    W[i["v_c"], CALIPER_FORCE] = 1.0 / p.caliper_mass
    C = np.zeros((3, n))
    C[0, i["p_b"]] = 1.0
    C[1, i["x_p"]] = p.block_stiffness
    C[2, i["x_c"]] = 1.0
    s = np.array([STATE_SCALE[name] for name in names])
    return _Plant(A * s[None, :] / s[:, None], B / s, W / s[:, None], C * s[None, :], s, i)


Discrete = tuple[FloatArray, FloatArray, FloatArray, FloatArray]


def _discretize(plant: _Plant, h: float) -> Discrete:
    """FOH on ``p_i``, ZOH on the explicit inputs: ``(Phi, G_prev, G_now, G_w)``."""
    n = plant.A.shape[0]
    block = np.zeros((n + 2 + INPUTS, n + 2 + INPUTS))
    block[:n, :n] = plant.A * h
    block[:n, n] = plant.B * h
    block[n, n + 1] = 1.0
    block[:n, n + 2 :] = plant.W * h
    e = scipy.linalg.expm(block)
    return e[:n, :n], e[:n, n] - e[:n, n + 1], e[:n, n + 1], e[:n, n + 2 :]


@dataclass(frozen=True)
class _Tables:
    phi: FloatArray  # (T, L, M, n, n)
    g_prev: FloatArray  # (T, L, M, n)
    g_now: FloatArray  # (T, L, M, n)
    g_w: FloatArray  # (T, L, M, n, INPUTS)
    plant: _Plant  # the plant at the start (block 0, gauge zero, stuck)


def _tables(
    spec: ModelSpec, b: int, pressures: FloatArray, blocks: int, block_s: float, h: float
) -> _Tables:
    p = spec.params[b]
    hose = None if spec.hose_compliance is None else float(spec.hose_compliance[b])
    spring = 0.0 if spec.jenkins_spring is None else float(spec.jenkins_spring[b])
    states = (STUCK, SLIPPING) if spec.has_jenkins else (STUCK,)
    sides = (APPLY, RELEASE) if spec.stiffness_asymmetry is not None else (APPLY,)
    asymmetry = 0.0 if spec.stiffness_asymmetry is None else float(spec.stiffness_asymmetry[b])
    modes = [(state, side) for state in states for side in sides]
    entries: list[list[list[Discrete]]] = []
    start: _Plant | None = None
    for block in range(blocks):
        line_drift = seal_drift = 1.0
        if spec.drift_rate is not None:
            reference = 0.0 if spec.drift_reference is None else float(spec.drift_reference[b])
            elapsed = (block + 0.5) * block_s - reference
            line_drift = max(1.0 + float(spec.drift_rate[b]) * elapsed, 0.05)
            if spec.seal_drift_rate is not None:
                seal_drift = max(1.0 + float(spec.seal_drift_rate[b]) * elapsed, 0.05)
        row = []
        for pressure in pressures:
            compliance = p.bore_compliance
            if spec.air_volume is not None:
                absolute = max(float(pressure), 0.0) + ATMOSPHERE
                compliance += float(spec.air_volume[b]) * ATMOSPHERE / absolute**2
            by_mode = []
            for state, side in modes:
                side_factor = 1.0 - asymmetry if side == APPLY else 1.0 + asymmetry
                plant = _plant(
                    p,
                    relative_stiffness=seal_drift * side_factor * p.effective_hydraulic_stiffness
                    + (spring if state == STUCK else 0.0),
                    relative_damping=seal_drift * p.effective_hydraulic_damping,
                    line_resistance=line_drift * p.line_resistance,
                    bore_compliance=compliance,
                    hose_compliance=hose,
                    hose_resistance_share=_hose_share(spec, b),
                )
                start = start or plant
                by_mode.append(_discretize(plant, h))
            row.append(by_mode)
        entries.append(row)
    assert start is not None
    stacked = [
        np.array([[[m[j] for m in lvl] for lvl in row] for row in entries]) for j in range(4)
    ]
    return _Tables(stacked[0], stacked[1], stacked[2], stacked[3], start)


def _hose_share(spec: ModelSpec, b: int) -> float:
    """Part of the line resistance beyond the hose node (0.3 when the spec leaves it)."""
    return 0.3 if spec.hose_resistance_share is None else float(spec.hose_resistance_share[b])


def _simulate_linear(spec: ModelSpec, u: FloatArray, sample_time: float) -> FloatArray:
    """Linear candidates through the vectorised modal simulation of the LTI model."""
    out = np.empty((spec.batch, 3, u.size))
    for b, p in enumerate(spec.params):
        hose = None if spec.hose_compliance is None else float(spec.hose_compliance[b])
        plant = _plant(
            p,
            relative_stiffness=p.effective_hydraulic_stiffness,
            relative_damping=p.effective_hydraulic_damping,
            line_resistance=p.line_resistance,
            bore_compliance=p.bore_compliance,
            hose_compliance=hose,
            hose_resistance_share=_hose_share(spec, b),
        )
        phi, g_prev, g_now, _ = _discretize(plant, sample_time)
        model = DiscreteModel(
            transition=phi,
            input_previous=g_prev,
            input_current=g_now,
            output_matrix=plant.C,
            equilibrium_gain=np.asarray(-np.linalg.solve(plant.A, plant.B), dtype=float),
            sample_time=sample_time,
            output_names=("p_b", "F_k", "x_c"),
        )
        out[b] = simulate(model, u)
    return _delay_outputs(spec, out, sample_time)


def _delay_outputs(spec: ModelSpec, out: FloatArray, sample_time: float) -> FloatArray:
    """Shift each channel by its acquisition delay (linear interpolation)."""
    if spec.output_delay is None:
        return out
    time = np.arange(out.shape[-1]) * sample_time
    for b in range(spec.batch):
        for channel in range(3):
            delay = float(spec.output_delay[b, channel])
            if delay != 0.0:
                out[b, channel] = np.interp(time - delay, time, out[b, channel])
    return out


class Integrator:
    """The candidate models' state, advanced one sample at a time for a batch of sets.

    :func:`simulate_batch` runs it over a recording;
    :class:`~brake_hil.live.improved.CandidateStepper` runs one set live, sample by sample;
    both give the same numbers for the same inputs.
    """

    def __init__(
        self,
        spec: ModelSpec,
        first_pressure: float,
        sample_time: float,
        pressure_ceiling: float,
        duration: float,
        pressure_levels: int = 16,
        block_s: float = 1.0,
        start_time: float = 0.0,
    ) -> None:
        batch = spec.batch
        self.spec, self.sample_time, self.block_s = spec, sample_time, block_s
        self.start_time, self.levels = start_time, pressure_levels
        self.air = spec.air_volume is not None
        self.drifting = spec.drift_rate is not None
        self.jenkins = spec.has_jenkins
        self.asymmetric = spec.stiffness_asymmetry is not None
        self.grid = (
            np.linspace(0.0, max(pressure_ceiling, 1e5), pressure_levels)
            if self.air
            else np.zeros(1)
        )
        self.blocks = int(np.ceil((start_time + duration) / block_s)) + 1 if self.drifting else 1
        tables = [
            _tables(spec, b, self.grid, self.blocks, block_s, sample_time) for b in range(batch)
        ]
        self.phi = np.stack([t.phi for t in tables])
        self.g_prev = np.stack([t.g_prev for t in tables])
        self.g_now = np.stack([t.g_now for t in tables])
        self.g_w = np.stack([t.g_w for t in tables])
        self.out_c = np.stack([t.plant.C for t in tables])
        self.z = np.stack(
            [-np.linalg.solve(t.plant.A, t.plant.B * first_pressure) for t in tables]
        )
        plant = tables[0].plant
        self.scale, index = plant.scale, plant.index
        self.i_pb, self.i_xp, self.i_vp, self.i_xc, self.i_vc = (
            index[k] for k in ("p_b", "x_p", "v_p", "x_c", "v_c")
        )
        self.i_q = index.get("Q_p", index["Q_h"])
        self.rows = np.arange(batch)
        self.sides = 2 if self.asymmetric else 1
        self.side = np.zeros(batch, dtype=int)
        self.relaxed = self._seal()  # the seal's relaxed position, creeping toward x_p - x_c
        self.side_stiffness = np.array([p.effective_hydraulic_stiffness for p in spec.params])
        self.asymmetry = (
            spec.stiffness_asymmetry if spec.stiffness_asymmetry is not None else np.zeros(batch)
        )
        self.relaxation = (
            spec.relaxation_time if spec.relaxation_time is not None else np.full(batch, 1.0)
        )
        self.level = np.zeros(batch, dtype=int)
        self.mode = np.zeros(batch, dtype=int)
        self.offset = np.zeros(batch)  # x_p - x_c at which the stuck Jenkins spring is relaxed
        self.direction = np.zeros(batch)  # +1 slipping while applying, -1 while releasing
        self.explicit = np.zeros((batch, INPUTS))
        self.apply_f = (
            spec.apply_threshold if spec.apply_threshold is not None else np.zeros(batch)
        )
        self.release_f = (
            spec.release_threshold if spec.release_threshold is not None else self.apply_f
        )
        self.bore_area = np.array([p.bore_area for p in spec.params])
        self.step_index = 0

    def _value(self, state: int) -> FloatArray:
        return np.asarray(self.z[:, state] * self.scale[state], dtype=float)

    def _seal(self) -> FloatArray:
        return self._value(self.i_xp) - self._value(self.i_xc)

    def outputs(self) -> FloatArray:
        """Current outputs (B, 3): p_b (Pa), F_k (N), x_c (m)."""
        return np.asarray(np.einsum("bij,bj->bi", self.out_c, self.z), dtype=float)

    def advance(self, previous_pressure: float, pressure: float) -> FloatArray:
        """Advance one sample (inputs in Pa, linear between them); return the outputs."""
        spec, explicit = self.spec, self.explicit
        self.step_index += 1
        block = 0
        if self.drifting:
            now = self.start_time + self.step_index * self.sample_time
            block = min(int(now / self.block_s), self.blocks - 1)
        p_b = self._value(self.i_pb)
        if self.air:
            self.level = np.clip(np.searchsorted(self.grid, p_b), 0, self.levels - 1)
        explicit[:, RELATIVE_FORCE] = 0.0
        if self.jenkins:
            assert spec.jenkins_spring is not None
            extra = self._bore_threshold(p_b)
            slip_force = np.where(self.direction > 0, self.apply_f, self.release_f) + extra
            explicit[:, RELATIVE_FORCE] = np.where(
                self.mode == STUCK,
                spec.jenkins_spring * self.offset,
                -self.direction * slip_force,
            )
        if spec.orifice_coefficient is not None:
            q = self._value(self.i_q)
            explicit[:, LINE_DROP] = spec.orifice_coefficient * q * np.abs(q)
        if spec.share_slope is not None:
            explicit[:, CALIPER_FORCE] = (
                -self.bore_area
                * spec.share_slope
                * p_b
                * (p_b - REFERENCE_PRESSURE)
                / REFERENCE_PRESSURE
            )
        if self.asymmetric:
            # Seal force k x_s - a k |x_s - x_r|: the tables carry k (1 -+ a) x_s, this the rest.
            sign = np.where(self.side == APPLY, -1.0, 1.0)
            explicit[:, RELATIVE_FORCE] += (
                sign * self.asymmetry * self.side_stiffness * self.relaxed
            )
        index = (self.rows, block, self.level, self.mode * self.sides + self.side)
        self.z = (
            np.einsum("bij,bj->bi", self.phi[index], self.z)
            + self.g_prev[index] * previous_pressure
            + self.g_now[index] * pressure
            + np.einsum("bij,bj->bi", self.g_w[index], explicit)
        )
        if self.jenkins:
            self._update_slider()
        if self.asymmetric:
            seal = self._seal()
            self.relaxed = (
                self.relaxed + (seal - self.relaxed) * self.sample_time / self.relaxation
            )
            self.side = np.where(seal >= self.relaxed, APPLY, RELEASE)
        return self.outputs()

    def _bore_threshold(self, p_b: FloatArray) -> FloatArray | float:
        if self.spec.bore_friction is None:
            return 0.0
        return np.asarray(self.spec.bore_friction * np.abs(p_b * self._value(self.i_xc)))

    def _update_slider(self) -> None:
        """Stick-slip transitions of the Jenkins element after a step (return mapping)."""
        spring = self.spec.jenkins_spring
        assert spring is not None
        seal = self._seal()
        velocity = self._value(self.i_vp) - self._value(self.i_vc)
        extra = self._bore_threshold(self._value(self.i_pb))
        mode, direction = self.mode, self.direction
        trial = spring * (seal - self.offset)
        start_apply = (mode == STUCK) & (trial > self.apply_f + extra)
        start_release = (mode == STUCK) & (trial < -(self.release_f + extra))
        stick = (mode == SLIPPING) & (direction * velocity <= 0.0)
        held = np.where(direction > 0, self.apply_f, self.release_f) + extra
        self.offset = np.where(stick, seal - direction * held / spring, self.offset)
        self.direction = np.where(start_apply, 1.0, np.where(start_release, -1.0, direction))
        self.mode = np.where(start_apply | start_release, SLIPPING, np.where(stick, STUCK, mode))


def simulate_batch(
    spec: ModelSpec,
    pressure: FloatArray,
    sample_time: float,
    pressure_levels: int = 16,
    block_s: float = 1.0,
    start_time: float = 0.0,
    pressure_ceiling: float | None = None,
) -> FloatArray:
    """Outputs ``(B, 3, N)`` (p_b Pa, F_k N, x_c m) of every parameter set of ``spec``
    driven by ``pressure`` (Pa, one sample per ``sample_time`` s), from the equilibrium at
    the first sample with every slider relaxed. ``start_time`` (s) is the first sample's time
    in the recording (the drift schedule runs on recording time); the entrained-air schedule
    spans 0 to ``pressure_ceiling`` (Pa; default 1.2 times the input's maximum).
    """
    u = np.asarray(pressure, dtype=float)
    if spec.is_linear:
        return _simulate_linear(spec, u, sample_time)
    ceiling = 1.2 * float(u.max()) if pressure_ceiling is None else pressure_ceiling
    integrator = Integrator(
        spec,
        float(u[0]),
        sample_time,
        ceiling,
        u.size * sample_time,
        pressure_levels,
        block_s,
        start_time,
    )
    out = np.empty((spec.batch, 3, u.size))
    out[:, :, 0] = integrator.outputs()
    for k in range(1, u.size):
        out[:, :, k] = integrator.advance(u[k - 1], u[k])
    return _delay_outputs(spec, out, sample_time)
