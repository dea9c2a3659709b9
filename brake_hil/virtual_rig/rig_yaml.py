"""Rig descriptions back to YAML: what the test engineer's rig file says (interface.md).

:func:`rig_to_mapping` is the inverse of :func:`brake_hil.physics.rig.rig_from_mapping`:
``rig_from_mapping(rig_to_mapping(rig))`` gives the same values. Floats are written in their
shortest exact form, so a perturbed truth rig survives the round trip bit for bit.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
import re
from typing import Any

import yaml

from brake_hil.physics.rig import Rig, rig_from_mapping


class _RigDumper(yaml.SafeDumper):
    """SafeDumper writing floats in their shortest exact form (``4.0e7``, ``0.012``)."""


def format_float(value: float) -> str:
    """Shortest text that reads back as exactly ``value``: plain, or ``4.0e7`` style."""
    value = float(value)
    if value == 0.0 or 1e-3 <= abs(value) < 1e5:
        return repr(value)
    for digits in range(1, 18):
        text = f"{value:.{digits}e}"
        if float(text) == value:
            break
    mantissa, exponent = text.split("e")
    mantissa = mantissa.rstrip("0")
    mantissa = mantissa + "0" if mantissa.endswith(".") else mantissa
    return f"{mantissa}e{int(exponent)}"


def _float(dumper: yaml.SafeDumper, value: float) -> yaml.ScalarNode:
    return dumper.represent_scalar("tag:yaml.org,2002:float", format_float(value))


_RigDumper.add_representer(float, _float)
_RigDumper.add_implicit_resolver(  # as brake_hil.physics.rig's loader reads them: untagged
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:\d+\.?\d*|\.\d+)[eE][-+]?\d+$"),
    list("-+0123456789."),
)


def rig_to_mapping(rig: Rig) -> dict[str, Any]:
    """The ``{"rig": {...}}`` document of a Rig (every value SI, nested as interface.md)."""
    body: dict[str, Any] = {
        "name": rig.name,
        "washers": rig.washers,
        "washer_thickness": rig.washer_thickness,
        "pistons": {
            "count": rig.piston_count,
            "diameter": rig.piston_diameter,
            "mass": rig.piston_mass,
        },
        "bore": {"area_ratio": rig.bore_area_ratio, "length": rig.bore_length},
        "caliper": {
            "mass": rig.caliper_mass,
            "stiffness": rig.caliper_stiffness,
            "transducer_distance": rig.transducer_distance,
        },
        "block": {"stiffness": rig.block_stiffness},
        "seal": dict(vars(rig.seal)),
        "bore_friction_coefficient": rig.bore_friction_coefficient,
        "fluid": dict(vars(rig.fluid)),
        "hard_pipe": dict(vars(rig.hard_pipe)),
        "hose": dict(vars(rig.hose)),
        "needle_valve": {"resistance": rig.needle_valve_resistance},
        "excitation_hz": rig.excitation_hz,
        "master_cylinder": dict(vars(rig.master_cylinder)),
    }
    if rig.model_overrides:
        body["model"] = dict(rig.model_overrides)
    if rig.tolerances:
        body["tolerances"] = dict(rig.tolerances)
    return {"rig": body}


def rig_with_values(rig: Rig, values: Mapping[str, float], name: str | None = None) -> Rig:
    """A copy of ``rig`` with values replaced by dotted key (``caliper.stiffness``), checked."""
    document = rig_to_mapping(rig)
    body = document["rig"]
    for dotted, value in values.items():
        *parents, leaf = dotted.split(".")
        node = body
        for parent in parents:
            node = node[parent]
        node[leaf] = value
    if name is not None:
        body["name"] = name
    return rig_from_mapping(document, source=rig.source)


def dump_rig(rig: Rig, comment: str = "") -> str:
    """The rig as YAML text, with ``comment`` lines (``# ...``) on top."""
    header = "".join(f"# {line}\n" if line else "#\n" for line in comment.splitlines())
    text = yaml.dump(
        rig_to_mapping(rig), Dumper=_RigDumper, sort_keys=False, default_flow_style=None, width=99
    )
    return header + text


def write_rig(rig: Rig, path: Path | str, comment: str = "") -> Path:
    """Write the rig as a YAML file (see :func:`dump_rig`); parent folders are created."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(dump_rig(rig, comment), encoding="utf-8")
    return path
