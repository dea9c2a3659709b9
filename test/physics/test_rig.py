"""Rig description: the YAML of docs/interface.md is loaded and checked at the door."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from brake_hil.errors import RigError
from brake_hil.physics.rig import load_rig, rig_from_mapping
from test.conftest import CONFIG


def _default_document() -> dict:  # type: ignore[type-arg]
    return yaml.safe_load(
        (CONFIG / "rig_default.yaml")
        .read_text()
        .replace("e7", "e+7")
        .replace("e9", "e+9")
        .replace("e6", "e+6")
        .replace("e11", "e+11")
        .replace("e10", "e+10")
        .replace("e-3", "e-03")
    )


def test_default_rig_holds_the_values_of_physics_md() -> None:
    rig = load_rig(CONFIG / "rig_default.yaml")
    assert rig.washers == 1
    assert rig.piston_diameter == 0.040
    assert rig.caliper_stiffness == 4.0e7  # written 4.0e7: read as a float, as YAML 1.2 does
    assert rig.seal.youngs_modulus == 9.2e6
    assert rig.needle_valve_resistance == 3.2e10
    assert rig.tolerance("caliper.stiffness") == 0.25
    assert rig.tolerance("bore.length") == 0.1


@pytest.mark.parametrize("name", ["rig_default", "rig_five_washers", "rig_restricted_valve"])
def test_bundled_rig_files_load(name: str) -> None:
    assert load_rig(CONFIG / f"{name}.yaml").name.startswith("nominal")


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda r: r["pistons"].update(mass=-0.2), "'pistons.mass' = -0.2 kg is implausible"),
        (lambda r: r["pistons"].update(diameter=40), "'pistons.diameter' = 40 m is implausible"),
        (lambda r: r["seal"].pop("width"), "missing required rig key 'seal.width'"),
        (lambda r: r.update(colour="red"), "unknown rig key 'colour'"),
        (lambda r: r["hose"].update(stiffnes=1.0), "unknown rig key 'hose.stiffnes'"),
        (lambda r: r.update(washers=1.5), "'washers' must be a whole number"),
        (lambda r: r["fluid"].update(density="heavy"), "'fluid.density' must be a number"),
        (lambda r: r.update(model={"k_eh": -1.0}), "'model.k_eh' = -1.0 N/m is implausible"),
        (lambda r: r.update(model={"q": 1.0}), "unknown rig key 'model.q'"),
        (lambda r: r.update(tolerances={"caliper.stiff": 0.1}), "unknown rig key 'caliper.stiff'"),
    ],
)
def test_bad_rig_values_are_refused_naming_the_key(edit, message: str) -> None:  # type: ignore[no-untyped-def]
    document = _default_document()
    edit(document["rig"])
    with pytest.raises(RigError, match=message.replace("(", r"\(").replace(")", r"\)")) as info:
        rig_from_mapping(document, source="bad.yaml")
    assert str(info.value).startswith("bad.yaml: ")


def test_model_and_tolerance_mappings_are_read() -> None:
    document = _default_document()
    document["rig"]["model"] = {"k_eh": 5.0e6, "R_v": 6.4e10}
    document["rig"]["tolerances"] = {"caliper.stiffness": 0.02}
    rig = rig_from_mapping(document)
    assert rig.model_overrides == {"k_eh": 5.0e6, "R_v": 6.4e10}
    assert rig.tolerance("caliper.stiffness") == 0.02


def test_unreadable_and_invalid_files_name_the_file(tmp_path: Path) -> None:
    with pytest.raises(RigError, match="missing.yaml: cannot read rig file"):
        load_rig(tmp_path / "missing.yaml")
    broken = tmp_path / "broken.yaml"
    broken.write_text("rig: {washers: [1,\n")
    with pytest.raises(RigError, match="broken.yaml: not valid YAML"):
        load_rig(broken)
    other = tmp_path / "other.yaml"
    other.write_text("caliper: {}\n")
    with pytest.raises(RigError, match="one top-level key 'rig'"):
        load_rig(other)
