"""The calibration's prior: every toleranced rig value carried into the quantities it sets.

The calibration (:mod:`.calibration`) fits log-multipliers ``m`` of a few model quantities
(``k_c``, ``R_v``, ``k_eh``, ``c_eh``, the air fraction, the hose wall, the bore chamber's
volume, the masses ...). Every other toleranced rig value (bore length, piston diameter, fluid
density and bulk modulus, pipe and hose geometry, viscosity ...) also reaches the LTI
coefficients (seed eqs. 2-20, :func:`~brake_hil.physics.parameters.derive_parameters`). Its
tolerance is carried into the prior of the multipliers linearly:

* ``B``: the log-Jacobian of the coefficients ``y`` (each calibrated field; ``C_b`` at two
  operating pressures, so its fixed and its air part both count) over the log of each
  toleranced rig value (finite differences, relative step ``STEP``);
* ``A``: the log-Jacobian of the same coefficients over the multipliers;
* the multipliers that reproduce a rig-value error best (least squares) are ``P = A^+ B``, so
  the prior covariance is ``P T^2 P^T`` with ``T`` the rig values' one-sigma tolerances
  (docs/interface.md; a rig file's ``tolerances:`` wins, 0 means exact).

Each multiplier's variance is then floored at its own key's tolerance squared (and the seed's
spread of ``k_eh``, ``c_eh``): a value the rig file overrides in ``model:`` keeps its own
tolerance as its prior, and no prior is tighter than the rig file's word for the value itself.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from brake_hil.physics.parameters import DEFAULT_MEAN_PRESSURE, ModelParameters, derive_parameters
from brake_hil.physics.rig import Rig
from brake_hil.types import FloatArray

STEP = 1.0e-3
"""Relative step of the finite differences (log units)."""
PRESSURES = (0.5 * DEFAULT_MEAN_PRESSURE, 2.0 * DEFAULT_MEAN_PRESSURE)
"""Operating pressures (Pa) the coefficients are compared at: ``C_b``'s air part falls as
``1/p``, its fixed part does not, so two pressures tell them apart."""
PARALLEL = 0.999
"""Cosine above which a rig value's column is one multiplier's."""
ROWS = (
    "caliper_stiffness",
    "block_stiffness",
    "effective_hydraulic_stiffness",
    "effective_hydraulic_damping",
    "line_resistance",
    "line_inertance",
    "piston_mass",
    "caliper_mass",
    "piston_area",
    "bore_area",
    "bore_compliance",
)
"""The LTI coefficients the calibration can move (``C_i`` is not: the master-cylinder pressure
is the model's input, its compliance only matters for an air-driven rig)."""

_LINE = ("length", "diameter", "wall", "youngs_modulus")
KEY_FIELDS: dict[str, tuple[str, ...]] = {
    "washer_thickness": ("washer_thickness",),
    "pistons.diameter": ("piston_diameter",),
    "pistons.mass": ("piston_mass",),
    "bore.area_ratio": ("bore_area_ratio",),
    "bore.length": ("bore_length",),
    "caliper.mass": ("caliper_mass",),
    "caliper.stiffness": ("caliper_stiffness",),
    "block.stiffness": ("block_stiffness",),
    **{
        f"seal.{k}": ("seal", k)
        for k in ("youngs_modulus", "poisson_ratio", "squeeze", "width", "shear_length")
    },
    **{f"fluid.{k}": ("fluid", k) for k in ("density", "viscosity", "bulk_modulus")},
    "fluid.air_fraction": ("fluid", "air_fraction"),
    **{f"hard_pipe.{k}": ("hard_pipe", k) for k in _LINE},
    **{f"hose.{k}": ("hose", k) for k in _LINE},
    "needle_valve.resistance": ("needle_valve_resistance",),
}
"""Every toleranced rig value that reaches the LTI coefficients: dotted key -> Rig attribute
path (``excitation_hz`` is measured from the recording; the seal's friction and loss factor
set no LTI coefficient)."""


def scaled(rig: Rig, key: str, factor: float) -> Rig:
    """``rig`` with the value of dotted ``key`` multiplied by ``factor``."""
    path = KEY_FIELDS[key]
    if len(path) == 1:
        return replace(rig, **{path[0]: getattr(rig, path[0]) * factor})
    part = getattr(rig, path[0])
    return replace(rig, **{path[0]: replace(part, **{path[1]: getattr(part, path[1]) * factor})})


def log_coefficients(params: tuple[ModelParameters, ...]) -> FloatArray:
    """The log of every row coefficient at each operating pressure, one vector."""
    values = [max(getattr(p, row), 1e-300) for p in params for row in ROWS]
    result: FloatArray = np.log(np.array(values, dtype=float))
    return result


def _jacobian(
    function: Callable[[FloatArray], FloatArray], size: int, base: FloatArray
) -> FloatArray:
    columns = []
    for j in range(size):
        step = np.zeros(size)
        step[j] = STEP
        columns.append((function(step) - base) / STEP)
    return np.array(columns).T


def _project(a: FloatArray, b: FloatArray) -> FloatArray:
    """Multipliers per log rig value (the projection of ``b`` on ``a``'s columns).

    A value whose effect on the coefficients is one multiplier's (parallel columns) is
    carried by that multiplier alone; the others by the least-squares, least-norm
    combination (``C_b``'s bore volume, hose wall and air share two rows: the split of what
    no recording tells apart is the smallest).
    """
    projection = np.linalg.pinv(a, rcond=1e-6) @ b
    norms = np.linalg.norm(a, axis=0)
    for k in range(b.shape[1]):
        column = b[:, k]
        size = float(np.linalg.norm(column))
        if size == 0.0:
            continue
        cosines = np.abs(a.T @ column) / np.maximum(norms * size, 1e-300)
        i = int(np.argmax(cosines))
        if cosines[i] > PARALLEL:
            projection[:, k] = 0.0
            projection[i, k] = float(a[:, i] @ column) / float(norms[i] ** 2)
    return projection


def prior_covariance(
    rig: Rig,
    names: list[str],
    apply: Callable[[Rig, float, dict[str, float]], ModelParameters],
    floors: dict[str, float],
    own: dict[str, float],
) -> tuple[FloatArray, dict[str, tuple[str, ...]]]:
    """The prior covariance of the log-multipliers ``names`` and the rig keys that set each.

    Args:
        rig: the rig file as loaded.
        names: the calibrated multipliers, in order.
        apply: ``calibration.apply_multipliers``.
        floors: each multiplier's least one-sigma (log units).
        own: one-sigma of each multiplier's own uncertainty that no propagated rig value
            carries (added independently): a ``model:`` override's tolerance, the seal's loss
            factor behind ``c_eh`` (the derivation takes the seed's).

    Returns:
        The covariance (len(names) square) and, per name, the dotted keys whose tolerance
        reaches it by more than a tenth of its own prior sigma (the words of a finding).
    """
    keys = [k for k in KEY_FIELDS if rig.tolerance(k) > 0.0]
    base = log_coefficients(tuple(derive_parameters(rig, p) for p in PRESSURES))

    def by_multipliers(step: FloatArray) -> FloatArray:
        m = dict(zip(names, np.exp(step).tolist()))
        return log_coefficients(tuple(apply(rig, p, m) for p in PRESSURES))

    def by_values(step: FloatArray) -> FloatArray:
        moved = rig
        for key, s in zip(keys, step):
            if s:
                moved = scaled(moved, key, float(np.exp(s)))
        return log_coefficients(tuple(derive_parameters(moved, p) for p in PRESSURES))

    a = _jacobian(by_multipliers, len(names), by_multipliers(np.zeros(len(names))))
    b = _jacobian(by_values, len(keys), base)
    projection = _project(a, b)
    tolerance = np.array([rig.tolerance(k) for k in keys])
    spread = projection * tolerance  # one sigma of each key, in each multiplier
    covariance = spread @ spread.T + np.diag([own.get(n, 0.0) ** 2 for n in names])
    floor = np.array([floors[n] ** 2 for n in names])
    covariance += np.diag(np.maximum(floor - np.diag(covariance), 0.0))
    sigma = np.sqrt(np.diag(covariance))
    setters = {
        name: tuple(
            key
            for key, share in sorted(zip(keys, spread[i]), key=lambda kv: -abs(kv[1]))
            if abs(share) > 0.25 * sigma[i]
        )
        for i, name in enumerate(names)
    }
    return covariance, setters
