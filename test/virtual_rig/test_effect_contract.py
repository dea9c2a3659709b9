"""Every effect through one contract: name, description with source, parameters, strength 0;
every catalogue entry has one truth law; a truth law registered at run time runs."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, fields
import re

import numpy as np
import pytest

from brake_hil.physics import catalogue
from brake_hil.physics.calibrated_values import VALUE_LABELS
from brake_hil.physics.catalogue import EffectEntry, Quantity, effect_names
from brake_hil.physics.rig import Rig
from brake_hil.virtual_rig import (
    EFFECTS,
    EffectError,
    build_plant,
    make_effect,
    parse_effect,
    seed_pulsing,
    simulate_rig,
)
from brake_hil.virtual_rig.effects import (
    OUT_OF_LIBRARY,
    STRENGTH,
    Effect,
    Parameter,
    register_effect,
    unregister_effect,
)
from brake_hil.virtual_rig.laws import LtiPlant, Signal, TruthLaw
from test.virtual_rig.conftest import RunFactory

INTERFACE_EFFECTS = effect_names()  # interface.md's effect table, less "unexplained"
ALL_EFFECTS = {**EFFECTS, **OUT_OF_LIBRARY}
EVERY_EFFECT = (*INTERFACE_EFFECTS, *OUT_OF_LIBRARY)  # the out-of-library ones keep it too
SHORT = {"max_pressures": (1.38e6,), "pulsing_s": 0.6}
CATALOGUE_ENTRIES = (*catalogue.CATALOGUE.values(), *catalogue.OUT_OF_LIBRARY.values())
SI_UNIT = re.compile(r"^(-|channel|(1|kg|m|s|N|Pa|K)(\^\d)?([ /*()]+(kg|m|s|N|Pa|K)(\^\d)?\)?)*)$")
"""A parameter's unit: dimensionless, a channel name, or SI symbols (``m^3/(Pa m)``)."""


def _truth_laws() -> Iterator[type[Effect]]:
    """Every Effect subclass defined anywhere, at any depth."""
    pending = list(Effect.__subclasses__())
    while pending:
        cls = pending.pop()
        pending.extend(cls.__subclasses__())
        yield cls


@pytest.mark.parametrize("item", CATALOGUE_ENTRIES, ids=lambda item: item.name)
def test_every_catalogue_entry_has_exactly_one_truth_law_with_its_signature(
    item: EffectEntry,
) -> None:
    pointing = [cls for cls in _truth_laws() if vars(cls).get("entry") is item]
    assert len(pointing) == 1, pointing
    (cls,) = pointing
    in_library = item.name in catalogue.CATALOGUE
    assert (EFFECTS if in_library else OUT_OF_LIBRARY)[item.name] is cls
    assert item.name not in (OUT_OF_LIBRARY if in_library else EFFECTS)
    assert cls.name == item.name
    assert cls.signature == item.signature
    assert make_effect(item.name).describe().count(item.signature) == 1
    for parameter in cls.parameters:
        assert SI_UNIT.match(parameter.unit), (parameter.name, parameter.unit)


@pytest.mark.parametrize("item", catalogue.CATALOGUE.values(), ids=lambda item: item.name)
def test_every_library_entry_says_what_the_reports_say_of_it(item: EffectEntry) -> None:
    assert item.rig_check and item.label and item.cause
    assert set(item.stands_in_for) <= set(VALUE_LABELS)


def test_the_truth_laws_follow_the_catalogue_order() -> None:
    assert tuple(EFFECTS) == tuple(catalogue.CATALOGUE)
    assert tuple(OUT_OF_LIBRARY) == tuple(catalogue.OUT_OF_LIBRARY)


_STIFF_MOUNT = EffectEntry(
    name="stiff_mount_test_only",
    title="the caliper sees more of the pressure force (a throw-away test effect)",
    physics="A constant extra share of A_eb p_b reaches the caliper.",
    source="seed eq. 22 (a test of the registration only)",
    signature="x_c larger than predicted by a constant factor; p_b and F_k unchanged",
    channels=("x_c",),
    quantities=(Quantity("d", "-", "extra share of the pressure force"),),
)


@dataclass(frozen=True)
class _ExtraShare(TruthLaw):
    extra: float

    def caliper_share(self, pressure_force: Signal) -> Signal:
        return 1.0 + self.extra + 0.0 * pressure_force


@dataclass(frozen=True)
class _StiffMount(Effect):
    """A throw-away effect: a constant extra share of the pressure force on the caliper, for
    testing that a truth law registered at run time runs through the virtual rig with no
    change to the host. Source: seed eq. 22 (2012)."""

    strength: float = 1.0
    extra_share: float = 0.2

    entry = _STIFF_MOUNT
    parameters = (STRENGTH, Parameter("extra_share", "-", 0.0, 0.5, "d at strength 1"))
    diagnosis_model = "a constant caliper force share"

    def law(self, plant: LtiPlant) -> _ExtraShare:
        del plant
        return _ExtraShare(self.strength * self.extra_share)


@pytest.fixture
def stiff_mount() -> Iterator[type[Effect]]:
    catalogue.register(_STIFF_MOUNT)
    try:
        yield register_effect(_StiffMount)
    finally:
        unregister_effect(_STIFF_MOUNT.name)
        catalogue.unregister(_STIFF_MOUNT.name)


def test_a_truth_law_registered_at_run_time_runs_through_the_virtual_rig(
    stiff_mount: type[Effect], rig_run: RunFactory
) -> None:
    assert list(EFFECTS)[-1] == "stiff_mount_test_only"
    assert stiff_mount.signature == _STIFF_MOUNT.signature
    with pytest.raises(EffectError, match="has a truth law already"):
        register_effect(_StiffMount)
    plain = rig_run(**SHORT)
    effect = parse_effect("stiff_mount_test_only=0.5")
    run = simulate_rig(plain.plant.rig, [effect], seed_pulsing((1.38e6,), pulsing_s=0.6))
    assert [effect.name for effect in run.effects] == ["stiff_mount_test_only"]
    assert np.allclose(run.internals["caliper_force_share"], 1.1, rtol=1e-12)
    assert np.array_equal(run.measured["p_i"], plain.measured["p_i"])
    ratio = np.max(np.abs(run.caliper_displacement)) / np.max(np.abs(plain.caliper_displacement))
    assert 1.05 < ratio < 1.15


def test_unregistered_truth_laws_are_gone_and_need_their_catalogue_entry() -> None:
    assert "stiff_mount_test_only" not in EFFECTS
    with pytest.raises(EffectError, match="unknown effect"):
        make_effect("stiff_mount_test_only")
    with pytest.raises(EffectError, match="unknown effect"):
        register_effect(_StiffMount)  # its catalogue entry is not registered


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


@dataclass(frozen=True)
class _WiderValve(TruthLaw):
    factor: float

    def valve_drop(
        self,
        flow: Signal,
        linear_resistance: float,
        viscosity_factor: Signal,
        linear_factor: Signal,
    ) -> Signal:
        return self.factor * linear_resistance * linear_factor * flow


@dataclass(frozen=True)
class _WiderValveEffect(Effect):
    """A throw-away effect replacing the valve's drop, for testing that two laws cannot
    replace one part of the rig. Source: seed eqs. 15-17 (2012)."""

    strength: float = 1.0

    entry = EffectEntry(
        name="wider_valve_test_only",
        title="a throw-away valve law",
        physics="The valve's resistance scaled.",
        source="seed eqs. 15-17",
        signature="p_b larger than predicted",
        channels=("p_b",),
        quantities=(),
    )
    parameters = (STRENGTH,)
    diagnosis_model = "a line resistance"

    def law(self, plant: LtiPlant) -> _WiderValve:
        del plant
        return _WiderValve(1.0 - 0.5 * self.strength)


def test_two_laws_cannot_replace_one_part_of_the_rig(nominal_rig: Rig) -> None:
    plant = build_plant(nominal_rig, [_WiderValveEffect()])
    assert [type(law) for law in plant.laws] == [_WiderValve]
    with pytest.raises(EffectError, match="orifice_flow and wider_valve_test_only both replace"):
        build_plant(nominal_rig, [make_effect("orifice_flow"), _WiderValveEffect()])
