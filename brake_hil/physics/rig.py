"""Rig description: the YAML of docs/interface.md, loaded and checked once at the door.

Every value is SI. A key that is unknown, missing, of the wrong type or of an implausible
magnitude (a negative mass, a 40 m piston) is refused with a `RigError` naming the file and
the dotted key. The optional ``master_cylinder`` mapping is this project's extension for the
air-pressure input (seed eqs. 21a-b); ``model`` overrides derived model parameters and
``tolerances`` gives one-sigma relative uncertainties by dotted key.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

from brake_hil.errors import RigError
from brake_hil.files import finite, load_yaml, read_text


class Bound(NamedTuple):
    """Plausible range of one rig value (SI)."""

    low: float
    high: float
    unit: str
    integer: bool = False


# Plausible magnitudes: wide enough for any passenger-car or motorcycle caliper rig,
# narrow enough to catch mm-for-m and sign mistakes.
SCHEMA: dict[str, Any] = {
    "name": str,
    "washers": Bound(1, 20, "-", integer=True),
    "washer_thickness": Bound(1e-4, 1e-2, "m"),
    "pistons": {
        "count": Bound(1, 8, "-", integer=True),
        "diameter": Bound(0.01, 0.12, "m"),
        "mass": Bound(0.005, 5.0, "kg"),
    },
    "bore": {"area_ratio": Bound(1.0, 2.0, "-"), "length": Bound(1e-3, 0.1, "m")},
    "caliper": {
        "mass": Bound(0.1, 50.0, "kg"),
        "stiffness": Bound(1e5, 1e10, "N/m"),
        "transducer_distance": Bound(0.01, 1.0, "m"),
    },
    "block": {"stiffness": Bound(1e6, 1e12, "N/m")},
    "seal": {
        "youngs_modulus": Bound(1e5, 1e9, "Pa"),
        "poisson_ratio": Bound(0.0, 0.5, "-"),
        "squeeze": Bound(0.01, 0.5, "-"),
        "width": Bound(5e-4, 2e-2, "m"),
        "shear_length": Bound(1e-6, 5e-3, "m"),
        "friction_coefficient": Bound(0.01, 2.0, "-"),
        "loss_factor": Bound(0.0, 2.0, "-"),
    },
    "bore_friction_coefficient": Bound(0.0, 2.0, "-"),
    "fluid": {
        "density": Bound(500.0, 2000.0, "kg/m^3"),
        "viscosity": Bound(1e-4, 1.0, "Pa s"),
        "bulk_modulus": Bound(1e8, 1e10, "Pa"),
        "air_fraction": Bound(0.0, 0.2, "-"),
    },
    "hard_pipe": {
        "length": Bound(0.0, 20.0, "m"),
        "diameter": Bound(5e-4, 0.05, "m"),
        "wall": Bound(1e-4, 0.02, "m"),
        "youngs_modulus": Bound(1e7, 1e12, "Pa"),
    },
    "hose": {
        "length": Bound(0.0, 20.0, "m"),
        "diameter": Bound(5e-4, 0.05, "m"),
        "wall": Bound(1e-4, 0.02, "m"),
        "youngs_modulus": Bound(1e6, 1e12, "Pa"),
    },
    "needle_valve": {"resistance": Bound(0.0, 1e14, "Pa s/m^3")},
    "excitation_hz": Bound(0.1, 100.0, "Hz"),
}

MASTER_CYLINDER_SCHEMA: dict[str, Bound] = {
    "diameter": Bound(5e-3, 0.06, "m"),  # d_i
    "length": Bound(1e-3, 0.3, "m"),  # l_i, fluid column
    "mass": Bound(0.01, 20.0, "kg"),  # M_i, pushrod, pistons, air-cylinder rod
    "spring_stiffness": Bound(0.0, 1e7, "N/m"),  # k_i, return spring
    "air_piston_diameter": Bound(5e-3, 0.5, "m"),  # sets A_a
}
DEFAULT_MASTER_CYLINDER: dict[str, float] = {
    "diameter": 0.01905,  # 3/4 in, a common master cylinder bore
    "length": 0.080,  # fluid column ahead of the primary piston
    "mass": 0.5,
    "spring_stiffness": 5.0e3,
    "air_piston_diameter": 0.050,
}

MODEL_OVERRIDE_KEYS: dict[str, Bound] = {
    "k_eh": Bound(1e3, 1e10, "N/m"),
    "c_eh": Bound(0.0, 1e8, "N s/m"),
    "C_b": Bound(1e-18, 1e-9, "m^3/Pa"),
    "C_i": Bound(1e-18, 1e-9, "m^3/Pa"),
    "R_v": Bound(0.0, 1e14, "Pa s/m^3"),
    "R_line": Bound(0.0, 1e14, "Pa s/m^3"),
    "I_line": Bound(0.0, 1e12, "Pa s^2/m^3"),
    "k_c": Bound(1e5, 1e10, "N/m"),
    "k_k": Bound(1e6, 1e12, "N/m"),
    "A_eb_over_A_ep": Bound(0.5, 3.0, "-"),
}

DEFAULT_TOLERANCES: dict[str, float] = {
    "caliper.stiffness": 0.25,
    "needle_valve.resistance": 0.4,
    "fluid.air_fraction": 1.0,
    **{f"seal.{key}": 0.3 for key in SCHEMA["seal"]},
}
DEFAULT_TOLERANCE = 0.1
"""Relative one-sigma uncertainty of any value not named in DEFAULT_TOLERANCES."""


@dataclass(frozen=True)
class Seal:
    """Rectangular piston seal (EPDM), per seal; seed eqs. 2-3, 6."""

    youngs_modulus: float  # E_s, Pa
    poisson_ratio: float  # nu_s
    squeeze: float  # eps_s
    width: float  # w_s, m
    shear_length: float  # l_s, m
    friction_coefficient: float  # mu_fs
    loss_factor: float  # eta_s


@dataclass(frozen=True)
class Line:
    """A fluid line: hard pipe or hose; seed eqs. 12-14, 18."""

    length: float  # l, m
    diameter: float  # d, m (inner)
    wall: float  # w, m
    youngs_modulus: float  # E, Pa


@dataclass(frozen=True)
class Fluid:
    """Brake fluid; seed eqs. 12-14, 18."""

    density: float  # rho, kg/m^3
    viscosity: float  # mu, Pa s
    bulk_modulus: float  # beta_y, Pa
    air_fraction: float  # j_a


@dataclass(frozen=True)
class MasterCylinder:
    """Master cylinder driven by an air cylinder (seed eqs. 21a-b); project extension."""

    diameter: float  # d_i, m
    length: float  # l_i, m
    mass: float  # M_i, kg
    spring_stiffness: float  # k_i, N/m
    air_piston_diameter: float  # m, sets A_a


@dataclass(frozen=True)
class Rig:
    """A rig as the test engineer describes it (nominal values, SI)."""

    name: str
    washers: int  # a
    washer_thickness: float  # w_w, m
    piston_count: int
    piston_diameter: float  # d_p, m
    piston_mass: float  # M_p, kg (all pistons)
    bore_area_ratio: float  # A_eb / A_ep
    bore_length: float  # l_b, m
    caliper_mass: float  # M_c, kg
    caliper_stiffness: float  # k_c, N/m
    transducer_distance: float  # l_c, m
    block_stiffness: float  # k_k, N/m
    seal: Seal
    bore_friction_coefficient: float  # mu_fb
    fluid: Fluid
    hard_pipe: Line
    hose: Line
    needle_valve_resistance: float  # R_v, Pa s/m^3 (linearised)
    excitation_hz: float  # f_e, Hz
    master_cylinder: MasterCylinder
    model_overrides: Mapping[str, float] = field(default_factory=dict)
    tolerances: Mapping[str, float] = field(default_factory=dict)
    source: str = "<memory>"

    def tolerance(self, dotted_key: str) -> float:
        """Relative one-sigma uncertainty of a value by its dotted key (docs/interface.md)."""
        if dotted_key in self.tolerances:
            return self.tolerances[dotted_key]
        return DEFAULT_TOLERANCES.get(dotted_key, DEFAULT_TOLERANCE)


def load_rig(path: Path | str) -> Rig:
    """Load and validate a rig YAML file; raise RigError naming the file and key.

    The file goes through the input door (:mod:`brake_hil.files`) first: a regular file of
    at most :data:`~brake_hil.files.RIG_FILE_MAX_BYTES`, UTF-8 text, strict YAML (no
    anchors, aliases, merge keys or duplicate keys; limited nesting and scalar length).
    """
    path = Path(path)
    text = read_text(path, "rig file", RigError)
    return rig_from_mapping(load_yaml(text, path, RigError), source=str(path))


def rig_from_mapping(document: object, source: str = "<memory>") -> Rig:
    """Validate a parsed rig document ``{"rig": {...}}`` and build a Rig."""
    if not isinstance(document, Mapping) or set(document) != {"rig"}:
        raise RigError(f"{source}: a rig file holds one top-level key 'rig'")
    raw = document["rig"]
    if not isinstance(raw, Mapping):
        raise RigError(f"{source}: 'rig' must be a mapping")
    extras = {"master_cylinder", "model", "tolerances"}
    values = _check_mapping(raw, SCHEMA, source, "", optional=extras)
    master = dict(DEFAULT_MASTER_CYLINDER)
    if "master_cylinder" in raw:
        master.update(
            _check_mapping(
                raw["master_cylinder"],
                MASTER_CYLINDER_SCHEMA,
                source,
                "master_cylinder.",
                all_optional=True,
            )
        )
    overrides = {}
    if "model" in raw:
        overrides = _check_mapping(
            raw["model"], MODEL_OVERRIDE_KEYS, source, "model.", all_optional=True
        )
    tolerances = _check_tolerances(raw.get("tolerances", {}), source)
    return Rig(
        name=values["name"],
        washers=values["washers"],
        washer_thickness=values["washer_thickness"],
        piston_count=values["pistons"]["count"],
        piston_diameter=values["pistons"]["diameter"],
        piston_mass=values["pistons"]["mass"],
        bore_area_ratio=values["bore"]["area_ratio"],
        bore_length=values["bore"]["length"],
        caliper_mass=values["caliper"]["mass"],
        caliper_stiffness=values["caliper"]["stiffness"],
        transducer_distance=values["caliper"]["transducer_distance"],
        block_stiffness=values["block"]["stiffness"],
        seal=Seal(**values["seal"]),
        bore_friction_coefficient=values["bore_friction_coefficient"],
        fluid=Fluid(**values["fluid"]),
        hard_pipe=Line(**values["hard_pipe"]),
        hose=Line(**values["hose"]),
        needle_valve_resistance=values["needle_valve"]["resistance"],
        excitation_hz=values["excitation_hz"],
        master_cylinder=MasterCylinder(**master),
        model_overrides=overrides,
        tolerances=tolerances,
        source=source,
    )


def _check_mapping(
    raw: object,
    schema: Mapping[str, Any],
    source: str,
    prefix: str,
    optional: set[str] | frozenset[str] = frozenset(),
    all_optional: bool = False,
) -> dict[str, Any]:
    if not isinstance(raw, Mapping):
        raise RigError(f"{source}: rig key '{prefix.rstrip('.')}' must be a mapping")
    unknown = sorted(str(key) for key in raw if key not in schema and key not in optional)
    if unknown:
        raise RigError(
            f"{source}: unknown rig key '{prefix}{unknown[0]}' "
            f"(expected one of: {', '.join(sorted(schema))})"
        )
    result: dict[str, Any] = {}
    for key, spec in schema.items():
        dotted = prefix + key
        if key not in raw:
            if all_optional:
                continue
            raise RigError(f"{source}: missing required rig key '{dotted}'")
        value = raw[key]
        if isinstance(spec, Mapping):
            result[key] = _check_mapping(value, spec, source, dotted + ".")
        elif spec is str:
            if not isinstance(value, str) or not value.strip():
                raise RigError(f"{source}: rig key '{dotted}' must be a non-empty string")
            result[key] = value
        else:
            result[key] = _check_number(value, spec, source, dotted)
    return result


def _check_number(value: object, bound: Bound, source: str, dotted: str) -> float | int:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise RigError(
            f"{source}: rig key '{dotted}' must be a number in {bound.unit}, got {_shown(value)}"
        )
    if not finite(value):
        raise RigError(
            f"{source}: rig key '{dotted}' must be a finite number in {bound.unit}, "
            f"got {_shown(value)}"
        )
    if bound.integer and float(value) != int(value):
        raise RigError(f"{source}: rig key '{dotted}' must be a whole number, got {_shown(value)}")
    number = float(value)
    if not bound.low <= number <= bound.high:
        raise RigError(
            f"{source}: rig key '{dotted}' = {_shown(value)} {bound.unit} is implausible "
            f"(expected {bound.low:g} to {bound.high:g} {bound.unit})"
        )
    return int(number) if bound.integer else number


def _shown(value: object) -> str:
    """``value`` for a one-line message: its repr, shortened to 40 characters."""
    text = " ".join(repr(value).split())
    return text if len(text) <= 40 else text[:37] + "..."


def _known_dotted_keys() -> set[str]:
    keys: set[str] = set()

    def walk(schema: Mapping[str, Any], prefix: str) -> None:
        for key, spec in schema.items():
            if isinstance(spec, Mapping):
                walk(spec, prefix + key + ".")
            elif spec is not str:
                keys.add(prefix + key)

    walk(SCHEMA, "")
    walk(MASTER_CYLINDER_SCHEMA, "master_cylinder.")
    walk(MODEL_OVERRIDE_KEYS, "model.")
    return keys


def _check_tolerances(raw: object, source: str) -> dict[str, float]:
    if not isinstance(raw, Mapping):
        raise RigError(f"{source}: rig key 'tolerances' must be a mapping of dotted keys")
    known = _known_dotted_keys()
    result = {}
    for key, value in raw.items():
        if key not in known:
            raise RigError(f"{source}: tolerances names unknown rig key '{key}'")
        result[str(key)] = float(
            _check_number(value, Bound(0.0, 10.0, "(relative)"), source, f"tolerances.{key}")
        )
    return result
