"""The linear plant of eq. 21c-f at one schedule entry, and its exact discretisation.

The plant as the terms leave it at that entry; the discretisation with first-order hold on
``p_i``, zero-order hold on the explicit inputs.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from brake_hil.physics.parameters import ModelParameters
from brake_hil.types import FloatArray

__all__ = [
    "CALIPER_FORCE",
    "INPUTS",
    "LINE_DROP",
    "RELATIVE_FORCE",
    "Coupling",
    "Discrete",
    "Plant",
    "build_plant",
    "discretize",
    "discretize_stack",
]

STATE_SCALE = {
    "Q_p": 1e-6,
    "p_h": 1e6,
    "p_r": 1e6,
    "Q_h": 1e-6,
    "p_b": 1e6,
    "x_p": 1e-6,
    "v_p": 1e-3,
    "x_c": 1e-5,
    "v_c": 1e-3,
}
"""Typical size of each state (SI): the plant is integrated in these units."""

RELATIVE_FORCE, CALIPER_FORCE, LINE_DROP = range(3)
"""Explicit inputs held over a step: a force between piston and caliper (N, + pushes the
piston out and the caliper back), a force on the caliper (N), a pressure drop in the line
(Pa, against the flow)."""
INPUTS = 3
HOSE_INERTANCE_SHARE = 0.3
"""Part of the line inertance beyond the hose node (the seed rig's 0.6 m hose of 2.1 m)."""


@dataclass
class Coupling:
    """How one set's linear plant differs from eq. 21c-f at one schedule entry.

    Terms change it in :meth:`~brake_hil.diagnosis.engine.terms.Term.couple`; the defaults
    are the LTI model.
    """

    stiffness_factor: float = 1.0  # -, multiplies k_eh
    extra_stiffness: float = 0.0  # N/m, in parallel with k_eh (a stuck Jenkins spring)
    damping_factor: float = 1.0  # -, multiplies c_eh
    line_factor: float = 1.0  # -, multiplies the line resistance R
    extra_compliance: float = 0.0  # m^3/Pa, added to the bore's C_b
    hose_compliance: float | None = None  # m^3/Pa, a node between pipe and hose (None: none)
    hose_resistance_share: float = 0.3  # -, part of R beyond the hose node
    hose_creep_compliance: float | None = None  # m^3/Pa, the node wall's retarded part C_d
    hose_creep_time: float = 0.02  # s, tau_w, its retardation time


@dataclass(frozen=True)
class Plant:
    """The continuous plant in scaled states (``x = scale * z``)."""

    A: FloatArray  # (n, n)
    B: FloatArray  # (n,) p_i input
    W: FloatArray  # (n, INPUTS) explicit inputs
    C: FloatArray  # (3, n) SI outputs p_b, F_k, x_c from scaled states
    scale: FloatArray  # (n,)
    index: dict[str, int]  # state name -> position


def build_plant(p: ModelParameters, coupling: Coupling) -> Plant:
    """Scaled continuous plant of eq. 21c-f with ``coupling`` applied."""
    relative_stiffness = (
        coupling.stiffness_factor * p.effective_hydraulic_stiffness + coupling.extra_stiffness
    )
    relative_damping = coupling.damping_factor * p.effective_hydraulic_damping
    line_resistance = coupling.line_factor * p.line_resistance
    bore_compliance = p.bore_compliance + coupling.extra_compliance
    hose_compliance = coupling.hose_compliance
    names = ["Q_h", "p_b", "x_p", "v_p", "x_c", "v_c"]
    creep = coupling.hose_creep_compliance if hose_compliance is not None else None
    if hose_compliance is not None:
        names = ["Q_p", "p_h", *(["p_r"] if creep is not None else []), *names]
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
        r_share, i_share = coupling.hose_resistance_share, HOSE_INERTANCE_SHARE
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
        if creep is not None:  # the wall's retarded swell: C_d (p_h - p_r) / tau_w more stored
            rate = 1.0 / coupling.hose_creep_time
            A[i["p_r"], i["p_h"]], A[i["p_r"], i["p_r"]] = rate, -rate
            A[i["p_h"], i["p_h"]] = -creep * rate / hose_compliance
            A[i["p_h"], i["p_r"]] = creep * rate / hose_compliance
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
    return Plant(A * s[None, :] / s[:, None], B / s, W / s[:, None], C * s[None, :], s, i)


Discrete = tuple[FloatArray, FloatArray, FloatArray, FloatArray]
"""``(Phi, G_prev, G_now, G_w)`` of one step: ``z' = Phi z + G_prev u_prev + G_now u +
G_w w``."""


def discretize(plant: Plant, h: float) -> Discrete:
    """FOH on ``p_i``, ZOH on the explicit inputs, over a step of ``h`` s."""
    phi, g_prev, g_now, g_w = discretize_stack([plant], h)
    return phi[0], g_prev[0], g_now[0], g_w[0]


def discretize_stack(plants: Sequence[Plant], h: float) -> Discrete:
    """:func:`discretize` of plants of one state layout, stacked along a first axis.

    One batched matrix exponential for all of them (:func:`expm_stack`): a schedule's
    tables hold hundreds of small plants, whose exponentials one at a time cost mostly call
    overhead.
    """
    n = plants[0].A.shape[0]
    block = np.zeros((len(plants), n + 2 + INPUTS, n + 2 + INPUTS))
    block[:, :n, :n] = np.array([plant.A for plant in plants]) * h
    block[:, :n, n] = np.array([plant.B for plant in plants]) * h
    block[:, n, n + 1] = 1.0
    block[:, :n, n + 2 :] = np.array([plant.W for plant in plants]) * h
    e = expm_stack(block)
    return e[:, :n, :n], e[:, :n, n] - e[:, :n, n + 1], e[:, :n, n + 1], e[:, :n, n + 2 :]


_PADE_13 = (
    64764752532480000.0,
    32382376266240000.0,
    7771770303897600.0,
    1187353796428800.0,
    129060195264000.0,
    10559470521600.0,
    670442572800.0,
    33522128640.0,
    1323241920.0,
    40840800.0,
    960960.0,
    16380.0,
    182.0,
    1.0,
)
_THETA_13 = 5.371920351148152
"""The 1-norm up to which the [13/13] Pade approximant is exact in double precision."""


def expm_stack(a: FloatArray) -> FloatArray:
    """Matrix exponentials of a stack of square matrices ``(K, m, m)``, in one pass.

    Scaling and squaring with the [13/13] Pade approximant (Higham, SIAM J. Matrix Anal.
    Appl. 26(4), 2005, Algorithm 2.3), each matrix scaled by its own power of two, every
    step one batched product over the stack. ``scipy.linalg.expm`` runs the same algorithm
    but takes a stack one matrix at a time in Python: on the diagnosis's schedule tables
    (hundreds of 16 x 16 blocks a call) that loop was most of a fit's time.
    """
    norms = np.abs(a).sum(axis=-2).max(axis=-1)
    squarings = np.maximum(0, np.ceil(np.log2(np.maximum(norms, 1e-300) / _THETA_13)))
    squarings = squarings.astype(int)
    scaled = a * np.exp2(-squarings)[:, None, None]
    b = _PADE_13
    identity = np.broadcast_to(np.eye(a.shape[-1]), a.shape)
    a2 = scaled @ scaled
    a4 = a2 @ a2
    a6 = a4 @ a2
    u = scaled @ (
        a6 @ (b[13] * a6 + b[11] * a4 + b[9] * a2)
        + b[7] * a6
        + b[5] * a4
        + b[3] * a2
        + b[1] * identity
    )
    v = a6 @ (b[12] * a6 + b[10] * a4 + b[8] * a2) + b[6] * a6 + b[4] * a4 + b[2] * a2
    v = v + b[0] * identity
    result: FloatArray = np.linalg.solve(v - u, v + u)
    for round_ in range(int(squarings.max(initial=0))):
        pending = squarings > round_
        result[pending] = result[pending] @ result[pending]
    return result
