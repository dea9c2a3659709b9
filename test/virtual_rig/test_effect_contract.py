"""Every effect through one contract: name, description with source, parameters, strength 0."""

from __future__ import annotations

from dataclasses import fields
import re

import numpy as np
import pytest

from brake_hil.physics.catalogue import effect_names
from brake_hil.virtual_rig import EFFECTS, EffectError, make_effect, parse_effect
from brake_hil.virtual_rig.effects import OUT_OF_LIBRARY, Effect
from test.virtual_rig.conftest import RunFactory

INTERFACE_EFFECTS = effect_names()  # interface.md's effect table, less "unexplained"
ALL_EFFECTS = {**EFFECTS, **OUT_OF_LIBRARY}
EVERY_EFFECT = (*INTERFACE_EFFECTS, *OUT_OF_LIBRARY)  # the out-of-library ones keep it too
SHORT = {"max_pressures": (1.38e6,), "pulsing_s": 0.6}


def test_the_library_holds_every_effect_of_interface_md_and_no_other() -> None:
    assert tuple(EFFECTS) == INTERFACE_EFFECTS
    assert not set(OUT_OF_LIBRARY) & set(INTERFACE_EFFECTS)


@pytest.mark.parametrize("name", EVERY_EFFECT)
def test_effect_has_its_interface_name(name: str) -> None:
    assert ALL_EFFECTS[name].name == name
    assert make_effect(name).name == name


@pytest.mark.parametrize("name", EVERY_EFFECT)
def test_effect_describes_its_physics_in_one_paragraph_with_a_source(name: str) -> None:
    cls = ALL_EFFECTS[name]
    description = cls.description()
    assert len(description) > 300, description
    assert "\n" not in description
    source = description[description.index("Source:") :]
    assert re.search(r"seed eqs?\. \d|seed's|\(\w[^)]*\d{4}\)|\d{4}", source), source
    assert cls.signature and cls.diagnosis_model
    text = make_effect(name).describe()
    assert text.startswith(f"{name}: ")
    for parameter in cls.parameters:
        assert f"{parameter.name} = " in text


@pytest.mark.parametrize("name", EVERY_EFFECT)
def test_effect_declares_every_parameter_with_unit_and_bounds(name: str) -> None:
    cls = ALL_EFFECTS[name]
    declared = [p.name for p in cls.parameters]
    assert declared[0] == "strength"
    assert sorted(declared) == sorted(f.name for f in fields(cls))
    default = cls()
    for parameter in cls.parameters:
        assert parameter.unit and parameter.description
        value = getattr(default, parameter.name)
        if parameter.choices:
            assert value in parameter.choices
        else:
            assert parameter.low < parameter.high
            assert parameter.low <= value <= parameter.high


@pytest.mark.parametrize("name", EVERY_EFFECT)
def test_effect_refuses_values_outside_its_bounds(name: str) -> None:
    with pytest.raises(EffectError, match=name):
        make_effect(name, 1.5)
    with pytest.raises(EffectError, match="strength"):
        make_effect(name, -0.1)
    numeric = [p for p in ALL_EFFECTS[name].parameters[1:] if not p.choices]
    if numeric:
        with pytest.raises(EffectError, match=numeric[0].name):
            make_effect(name, 0.5, **{numeric[0].name: numeric[0].high * 10 + 1})
    with pytest.raises(EffectError, match="unknown parameter"):
        make_effect(name, 0.5, no_such_parameter=1.0)


@pytest.mark.parametrize("name", EVERY_EFFECT)
def test_effect_at_strength_zero_changes_nothing(name: str, rig_run: RunFactory) -> None:
    plain = rig_run(**SHORT)
    zero = rig_run((name, 0.0), **SHORT)
    assert not zero.effects
    for key in ("p_i", "p_b", "F_k", "x_c"):
        assert np.array_equal(zero.true()[key], plain.true()[key])
        assert np.array_equal(zero.measured[key], plain.measured[key])


@pytest.mark.parametrize("name", EVERY_EFFECT)
def test_effect_at_full_strength_changes_the_recording(name: str, rig_run: RunFactory) -> None:
    plain = rig_run(**SHORT)
    full = rig_run((name, 1.0), **SHORT)
    assert [e.name for e in full.effects] == [name]
    changed = [
        key
        for key in ("p_b", "F_k", "x_c")
        if not np.allclose(full.measured[key], plain.measured[key], rtol=0, atol=0)
    ]
    assert changed
    assert all(np.all(np.isfinite(values)) for values in full.true().values())


def test_effects_parse_from_the_command_line_form() -> None:
    effect = parse_effect("sensor_delay=0.5,channel=p_b,delay=0.002")
    assert isinstance(effect, Effect)
    assert effect.values() == {
        "strength": 0.5,
        "channel": "p_b",
        "delay": 0.002,
        "filter_share": 0.25,
    }
    assert parse_effect("orifice_flow").strength == 1.0
    with pytest.raises(EffectError, match="unknown effect 'no_such'"):
        parse_effect("no_such=1")
    with pytest.raises(EffectError, match="not a number"):
        parse_effect("orifice_flow=strong")
    with pytest.raises(EffectError, match="channel"):
        parse_effect("sensor_delay=1,channel=q")


def test_sensor_nonlinearity_changes_only_its_channel_by_its_quadratic_law(
    rig_run: RunFactory,
) -> None:
    plain = rig_run(**SHORT)
    bent = rig_run(("sensor_nonlinearity", 1.0, {"channel": "F_k"}), **SHORT)
    for key in ("p_i", "p_b", "x_c"):
        assert np.array_equal(bent.measured[key], plain.measured[key])
    force = plain.block_force
    expected = force * (1.0 + 0.3 * force / 8.9e3)
    resolution = 8.9e3 / (2**16 - 1)
    error = bent.measured["F_k"] - plain.measured["F_k"] - (expected - force)
    assert np.max(np.abs(error)) <= 1.01 * resolution
