"""How a benchmark case's truth rig differs from the nominal rig file: the parameter errors.

Two spans of draws (``SPANS``), each a relative error ``truth / nominal - 1`` per dotted key:

* ``contract`` (the default): every toleranced rig value (:func:`spanned_keys`: every numeric
  key of the rig file, geometry, masses and the fluid's density included) drawn *uniformly*
  within plus or minus its whole tolerance (docs/interface.md: ``caliper.stiffness`` 25 %,
  ``needle_valve.resistance`` 40 %, all else 10 %), except the rig's own air fraction and the
  seal values, drawn within plus or minus 10 %: their documented tolerances (100 %, 30 %) say
  how little the *engineer* knows of them, not how far a benchmark rig may sit from its file
  while still being "the rig the file describes" (an air fraction at twice the file's is
  "more air", a case of its own; an independent set draws its air "within 10 % of the rig
  file's" too). Values are kept inside the rig file's plausible bounds (Poisson's ratio below
  0.5).
* ``seed``: the draw the stored sets of docs/benchmarks.md were made with, kept only so they
  can be replayed: ``PERTURBED_KEYS`` only (geometry taken as measured), each from a normal of
  standard deviation half its tolerance, clipped at one tolerance.

:func:`draw_out_of_tolerance` puts one value of ``OUT_OF_TOLERANCE_KEYS`` 1 to 2 tolerances
off (the ``out_of_tolerance`` kind); ``MORE_AIR_RATIOS`` bound the ``more_air`` kind's air.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from brake_hil.physics.rig import MASTER_CYLINDER_SCHEMA, SCHEMA, Bound, Rig
from brake_hil.virtual_rig.effects import EffectError
from brake_hil.virtual_rig.rig_yaml import rig_to_mapping

__all__ = [
    "MORE_AIR_RATIOS",
    "NARROW_SPAN",
    "OUT_OF_TOLERANCE_KEYS",
    "PERTURBED_KEYS",
    "SPANS",
    "draw_clipped_normal_errors",
    "draw_out_of_tolerance",
    "draw_parameter_errors",
    "draw_uniform_errors",
    "spanned_keys",
]

SPANS = ("contract", "seed")
"""The spans of parameter errors (see the module docstring); ``contract`` is the default."""

PERTURBED_KEYS = (
    "caliper.stiffness",
    "caliper.mass",
    "block.stiffness",
    "needle_valve.resistance",
    "seal.youngs_modulus",
    "seal.shear_length",
    "seal.friction_coefficient",
    "seal.loss_factor",
    "bore_friction_coefficient",
    "fluid.viscosity",
    "fluid.bulk_modulus",
    "fluid.air_fraction",
    "hose.youngs_modulus",
)
"""The ``seed`` span's keys (the catalogue-grade ones; geometry taken as measured)."""

NARROW_SPAN = 0.10
"""Relative half-width of the ``contract`` span of the air fraction and the seal values."""

_NOT_SPANNED = ("name", "washers", "pistons.count", "excitation_hz")
"""Rig-file keys no draw moves: the name, counts (integers) and the pulsing (a setting of the
drive, which the recording itself shows)."""

OUT_OF_TOLERANCE_KEYS = (
    "caliper.stiffness",
    "needle_valve.resistance",
    "seal.youngs_modulus",
    "seal.loss_factor",
    "block.stiffness",
    "fluid.bulk_modulus",
    "hose.youngs_modulus",
    "hose.wall",
    "hose.diameter",
    "hose.length",
    "bore.length",
    "pistons.diameter",
    "pistons.mass",
    "caliper.mass",
)
"""Where an ``out_of_tolerance`` case puts its one far value: the values the calibration
identifies or that set a calibrated quantity (compliances, stiffnesses, resistance, masses),
geometry included."""

MORE_AIR_RATIOS = (2.0, 3.0)
"""The ``more_air`` kind's air fraction over the rig file's (uniform between)."""


def spanned_keys(rig: Rig) -> tuple[str, ...]:
    """Every dotted key of ``rig``'s file that the ``contract`` span draws, in file order."""
    keys: list[str] = []

    def walk(node: Mapping[str, Any], prefix: str) -> None:
        for key, value in node.items():
            dotted = prefix + key
            if isinstance(value, Mapping):
                walk(value, dotted + ".")
            elif isinstance(value, float) and dotted not in _NOT_SPANNED:
                keys.append(dotted)

    document = rig_to_mapping(rig)["rig"]
    walk({k: v for k, v in document.items() if k not in ("model", "tolerances")}, "")
    return tuple(keys)


def contract_span(rig: Rig, key: str) -> float:
    """Relative half-width of ``key``'s uniform ``contract`` draw (see the module docstring)."""
    if key == "fluid.air_fraction" or key.startswith("seal."):
        return min(NARROW_SPAN, rig.tolerance(key))
    return rig.tolerance(key)


def _bound(key: str) -> Bound | None:
    node: Any = {**SCHEMA, "master_cylinder": MASTER_CYLINDER_SCHEMA}
    for part in key.split("."):
        node = node.get(part) if isinstance(node, Mapping) else None
    return node if isinstance(node, Bound) else None


def _value(rig: Rig, key: str) -> float:
    node: Any = rig_to_mapping(rig)["rig"]
    for part in key.split("."):
        node = node[part]
    return float(node)


def _inside_bounds(rig: Rig, key: str, error: float) -> float:
    """``error`` moved so ``value * (1 + error)`` stays inside the key's plausible bounds."""
    bound, value = _bound(key), _value(rig, key)
    if bound is None or value <= 0.0:
        return error
    highest = bound.high / value * (1.0 - 1e-4) - 1.0
    lowest = bound.low / value * (1.0 + 1e-4) - 1.0
    return float(min(max(error, lowest), highest))


def draw_uniform_errors(
    nominal: Rig, rng: np.random.Generator, error_scale: float = 1.0
) -> dict[str, float]:
    """The ``contract`` span: every :func:`spanned_keys` value uniform within its span."""
    errors = {}
    for key in spanned_keys(nominal):
        half = contract_span(nominal, key) * error_scale
        error = float(np.round(rng.uniform(-half, half), 4))
        errors[key] = _inside_bounds(nominal, key, error)
    return errors


def draw_clipped_normal_errors(
    nominal: Rig, rng: np.random.Generator, error_scale: float = 1.0
) -> dict[str, float]:
    """The ``seed`` span: ``PERTURBED_KEYS`` from a normal of half a tolerance, clipped at one."""
    errors = {}
    for key in PERTURBED_KEYS:
        sigma = nominal.tolerance(key) * error_scale
        errors[key] = float(np.round(np.clip(rng.normal(0.0, 0.5 * sigma), -sigma, sigma), 4))
    return errors


def draw_parameter_errors(
    nominal: Rig, rng: np.random.Generator, error_scale: float = 1.0, span: str = "contract"
) -> dict[str, float]:
    """Relative errors ``truth / nominal - 1`` of ``span`` (:data:`SPANS`).

    Raises:
        EffectError: an unknown span.
    """
    if span == "contract":
        return draw_uniform_errors(nominal, rng, error_scale)
    if span == "seed":
        return draw_clipped_normal_errors(nominal, rng, error_scale)
    raise EffectError(f"unknown span of parameter errors {span!r} (known: {', '.join(SPANS)})")


def draw_out_of_tolerance(nominal: Rig, rng: np.random.Generator) -> tuple[str, float]:
    """One key of ``OUT_OF_TOLERANCE_KEYS`` and its error: 1 to 2 tolerances off, either sign."""
    key = str(rng.choice(OUT_OF_TOLERANCE_KEYS))
    size = float(rng.uniform(1.0, 2.0)) * nominal.tolerance(key)
    sign = 1.0 if rng.uniform() < 0.5 else -1.0
    error = float(np.round(sign * size, 4))
    return key, _inside_bounds(nominal, key, max(error, -0.9))
