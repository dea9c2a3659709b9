"""The candidate models run for a batch of parameter sets at once.

Over a recording (:func:`simulate_batch`) or sample by sample (:class:`Integrator`).
"""

from __future__ import annotations

from dataclasses import dataclass
import itertools

import numpy as np

from brake_hil.diagnosis.engine.plant import (
    INPUTS,
    Coupling,
    Plant,
    build_plant,
    discretize,
    discretize_stack,
)
from brake_hil.diagnosis.engine.terms import Entry, ModelSpec, Step
from brake_hil.physics.lti_model import DiscreteModel, simulate
from brake_hil.types import FloatArray, IndexArray

__all__ = ["Integrator", "simulate_batch"]

Modes = tuple[int, ...]
"""One mode of every term of a spec, in the spec's order."""


def _plant(spec: ModelSpec, row: int, pressure: float, time: float, modes: Modes) -> Plant:
    """The linear plant of set ``row`` at one schedule entry."""
    coupling = Coupling()
    for term, mode in zip(spec.terms, modes):
        term.couple(coupling, row, Entry(pressure, time, mode))
    return build_plant(spec.params[row], coupling)


@dataclass(frozen=True)
class _Tables:
    phi: FloatArray  # (B, T, L, M, n, n)
    g_prev: FloatArray  # (B, T, L, M, n)
    g_now: FloatArray  # (B, T, L, M, n)
    g_w: FloatArray  # (B, T, L, M, n, INPUTS)
    plants: list[Plant]  # each set's plant at the start (block 0, gauge zero, modes 0)


def _tables(
    spec: ModelSpec,
    pressures: FloatArray,
    first_blocks: IndexArray,
    blocks: int,
    block_s: float,
    h: float,
    modes: list[Modes],
) -> _Tables:
    """Transition matrices of every set over pressure levels, modes and time blocks.

    ``blocks`` blocks from each set's own first (``first_blocks``, one per set).
    """
    plants = [
        _plant(spec, row, float(pressure), (block + 0.5) * block_s, mode)
        for row, first in enumerate(first_blocks.tolist())
        for block in range(first, first + blocks)
        for pressure in pressures
        for mode in modes
    ]
    shape = (spec.batch, blocks, len(pressures), len(modes))
    phi, g_prev, g_now, g_w = (m.reshape(shape + m.shape[1:]) for m in discretize_stack(plants, h))
    per_set = blocks * len(pressures) * len(modes)
    return _Tables(phi, g_prev, g_now, g_w, plants[::per_set])


def _simulate_linear(
    spec: ModelSpec, u: FloatArray, sample_time: float, start_time: FloatArray
) -> FloatArray:
    """Linear candidates through the vectorised modal simulation of the LTI model.

    ``u`` (Pa): one input for every set ``(N,)``, or one per set ``(B, N)``.
    """
    out = np.empty((spec.batch, 3, u.shape[-1]))
    modes = (0,) * len(spec.terms)
    for b in range(spec.batch):
        plant = _plant(spec, b, 0.0, 0.0, modes)
        phi, g_prev, g_now, _ = discretize(plant, sample_time)
        model = DiscreteModel(
            transition=phi,
            input_previous=g_prev,
            input_current=g_now,
            output_matrix=plant.C,
            equilibrium_gain=np.asarray(-np.linalg.solve(plant.A, plant.B), dtype=float),
            sample_time=sample_time,
            output_names=("p_b", "F_k", "x_c"),
        )
        out[b] = simulate(model, u if u.ndim == 1 else u[b])
    return _transform(spec, out, sample_time, start_time)


def _transform(
    spec: ModelSpec, out: FloatArray, sample_time: float, start_time: FloatArray
) -> FloatArray:
    """The terms' output transforms, in order (``start_time`` (B,) s, each set's first)."""
    for term in spec.terms:
        out = term.transform_at(out, sample_time, start_time)
    return out


class Integrator:
    """The candidate models' state, advanced one sample at a time for a batch of sets.

    :func:`simulate_batch` runs it over a recording;
    :class:`~brake_hil.live.improved.CandidateStepper` runs one set live, sample by sample;
    both give the same numbers for the same inputs. It is the :class:`~.terms.State` the
    terms' steps see.
    """

    def __init__(
        self,
        spec: ModelSpec,
        first_pressure: float | FloatArray,
        sample_time: float,
        pressure_ceiling: float,
        duration: float,
        pressure_levels: int = 16,
        block_s: float = 1.0,
        start_time: float | FloatArray = 0.0,
    ) -> None:
        """Every set at its equilibrium at ``first_pressure`` (Pa, one or one per set).

        ``start_time`` (s, one or one per set) is the recording time of the first sample
        (time-scheduled terms run on recording time); the pressure schedule spans 0 to
        ``pressure_ceiling`` (Pa) and the time schedule ``duration`` (s) after the latest start.
        """
        terms = spec.terms
        first = np.broadcast_to(np.asarray(first_pressure, dtype=float), (spec.batch,))
        self.spec, self.params = spec, spec.params
        self.sample_time, self.block_s = sample_time, block_s
        self.start_time, self.levels = start_time, pressure_levels
        self.on_pressure = any(t.pressure_scheduled for t in terms)
        self.on_time = any(t.time_scheduled for t in terms)
        self.grid = (
            np.linspace(0.0, max(pressure_ceiling, 1e5), pressure_levels)
            if self.on_pressure
            else np.zeros(1)
        )
        latest = float(np.max(start_time))
        self.blocks = int(np.ceil((latest + duration) / block_s)) + 1 if self.on_time else 1
        # Each set's table covers the blocks its own stretch of time reaches, no more (the
        # windows of a recording run as one batch, each from its own start).
        starts = np.broadcast_to(np.asarray(start_time, dtype=float), (spec.batch,))
        self.first_block: IndexArray = (
            np.minimum((starts / block_s).astype(np.intp), self.blocks - 1)
            if self.on_time
            else np.zeros(spec.batch, dtype=np.intp)
        )
        own_blocks = min(int(np.ceil(duration / block_s)) + 1, self.blocks) if self.on_time else 1
        modes = list(itertools.product(*(range(t.modes) for t in terms)))
        tables = _tables(
            spec, self.grid, self.first_block, own_blocks, block_s, sample_time, modes
        )
        # One matrix per schedule entry acting on [z, previous p_i, p_i, explicit inputs]:
        # a step is one batched product, its entry one flat index per set.
        system = np.concatenate(
            [tables.phi, tables.g_prev[..., None], tables.g_now[..., None], tables.g_w],
            axis=-1,
        )
        n = tables.phi.shape[-1]
        self.entries_per_block = tables.phi.shape[2] * tables.phi.shape[3]  # L * M
        self.modes_per_level = tables.phi.shape[3]
        self.system = np.ascontiguousarray(system.reshape(spec.batch, -1, n, system.shape[-1]))
        self.out_c = np.stack([plant.C for plant in tables.plants])
        self.z = np.stack([-np.linalg.solve(t.A, t.B * p) for t, p in zip(tables.plants, first)])
        self.drive = np.zeros((spec.batch, system.shape[-1], 1))  # [z, p_prev, p, explicit]
        self.states = n
        self.scale, self.index = tables.plants[0].scale, tables.plants[0].index
        self.si = self.z * self.scale  # the states in SI units
        self.rows = np.arange(spec.batch)
        self.level: IndexArray = np.zeros(spec.batch, dtype=np.intp)
        self.explicit = np.zeros((spec.batch, INPUTS))
        self.step_index = 0
        started = [(term, term.start(self)) for term in terms]
        self.steps: list[Step] = [step for _, step in started if step is not None]
        strides = np.cumprod([1, *(t.modes for t in reversed(terms))])[::-1][1:]
        self.moded: list[tuple[Step, int]] = []
        for (term, step), stride in zip(started, strides):
            if term.modes > 1:
                assert step is not None, f"{type(term).__name__} has modes but no step"
                self.moded.append((step, int(stride)))

    def value(self, name: str) -> FloatArray:
        """One state of the plant by name (SI)."""
        return self.si[:, self.index[name]]

    def seal(self) -> FloatArray:
        """Seal deflection ``x_p - x_c`` (m)."""
        return self.value("x_p") - self.value("x_c")

    def seal_velocity(self) -> FloatArray:
        """``v_p - v_c`` (m/s)."""
        return self.value("v_p") - self.value("v_c")

    def line_flow(self) -> FloatArray:
        """Flow through the valve (m^3/s): ``Q_p`` with a hose node, else ``Q_h``."""
        return self.value("Q_p" if "Q_p" in self.index else "Q_h")

    def outputs(self) -> FloatArray:
        """Current outputs (B, 3): p_b (Pa), F_k (N), x_c (m)."""
        return np.asarray(np.matmul(self.out_c, self.z[:, :, None])[:, :, 0], dtype=float)

    def advance(
        self, previous_pressure: float | FloatArray, pressure: float | FloatArray
    ) -> FloatArray:
        """Advance one sample and return the outputs (B, 3).

        Inputs in Pa, linear between them: one for every set, or one per set (B,).
        """
        self.step(previous_pressure, pressure)
        return self.outputs()

    def step(self, previous_pressure: float | FloatArray, pressure: float | FloatArray) -> None:
        """:meth:`advance` without the outputs (a batch reads them off the states at the end)."""
        self.step_index += 1
        block: IndexArray | int = 0
        if self.on_time:
            now = self.start_time + self.step_index * self.sample_time
            # each set's own table starts at its first block
            if isinstance(now, np.ndarray):
                block = np.minimum((now / self.block_s).astype(np.intp), self.blocks - 1)
                block = block - self.first_block
            else:  # one start for every set
                block = min(int(now / self.block_s), self.blocks - 1) - int(self.first_block[0])
        if self.on_pressure:
            p_b = self.value("p_b")
            self.level = np.minimum(np.searchsorted(self.grid, p_b), self.levels - 1)
        explicit = self.explicit
        explicit[:] = 0.0
        for step in self.steps:
            step.inputs(self, explicit)
        entry: IndexArray | int = block * self.entries_per_block
        if self.on_pressure:
            entry = entry + self.level * self.modes_per_level
        for step, stride in self.moded:
            digit = step.mode()
            entry = entry + (digit if stride == 1 else digit * stride)
        drive, n = self.drive, self.states
        drive[:, :n, 0] = self.z
        drive[:, n, 0] = previous_pressure
        drive[:, n + 1, 0] = pressure
        drive[:, n + 2 :, 0] = explicit
        if isinstance(entry, int):
            matrices = self.system[:, entry]
        else:
            matrices = self.system[self.rows, entry]
        self.z = np.matmul(matrices, drive)[:, :, 0]
        self.si = self.z * self.scale
        for step in self.steps:
            step.update(self)


def simulate_batch(
    spec: ModelSpec,
    pressure: FloatArray,
    sample_time: float,
    pressure_levels: int = 16,
    block_s: float = 1.0,
    start_time: float | FloatArray = 0.0,
    pressure_ceiling: float | None = None,
) -> FloatArray:
    """Outputs ``(B, 3, N)`` (p_b Pa, F_k N, x_c m) of every parameter set of ``spec``.

    Driven by ``pressure`` (Pa, one sample per ``sample_time`` s: ``(N,)`` for every set, or
    ``(B, N)``, one stretch of input per set, so several windows of a recording run as one
    batch), from the equilibrium at the first sample with every slider relaxed.
    ``start_time`` (s, one or one per set) is the first sample's time in the recording
    (time-scheduled terms run on recording time); the pressure schedule spans 0 to
    ``pressure_ceiling`` (Pa; default 1.2 times the input's maximum).
    """
    u = np.asarray(pressure, dtype=float)
    starts = np.broadcast_to(np.asarray(start_time, dtype=float), (spec.batch,))
    if spec.is_linear:
        return _simulate_linear(spec, u, sample_time, starts)
    ceiling = 1.2 * float(u.max()) if pressure_ceiling is None else pressure_ceiling
    samples = u.shape[-1]
    integrator = Integrator(
        spec,
        u[..., 0],
        sample_time,
        ceiling,
        samples * sample_time,
        pressure_levels,
        block_s,
        start_time if np.ndim(start_time) == 0 else np.asarray(start_time, dtype=float),
    )
    states = np.empty((samples, spec.batch, integrator.states))
    states[0] = integrator.z
    columns = u.T if u.ndim == 2 else u
    for k in range(1, samples):
        integrator.step(columns[k - 1], columns[k])
        states[k] = integrator.z
    out = np.einsum("boj,kbj->bok", integrator.out_c, states)
    return _transform(spec, out, sample_time, starts)
