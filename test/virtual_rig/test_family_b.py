"""Family b: a second truth law per effect, its cases, and family a's cases left as they were."""

from __future__ import annotations

from dataclasses import fields
import hashlib
import json
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest

from brake_hil.physics import catalogue
from brake_hil.virtual_rig import (
    EFFECTS,
    RigRun,
    build_plant,
    family_b,
    seed_pulsing,
    simulate_rig,
)
from brake_hil.virtual_rig.cases import nominal_rigs, plan_cases, select_cases
from brake_hil.virtual_rig.effects import OUT_OF_LIBRARY, Effect, EffectError, effect_class
from brake_hil.virtual_rig.family_b import EFFECTS_B, MeasurementChainB
from brake_hil.virtual_rig.family_b.sensor_delay import SensorDelayB
from brake_hil.virtual_rig.plant import base_plant
from test.virtual_rig.conftest import RunFactory

SHORT = {"max_pressures": (1.38e6,), "pulsing_s": 0.6}
CHANNELS = ("p_i", "p_b", "F_k", "x_c")

SEED_37_ROUND = (
    ("null", (), (), 1512157120),
    ("single", ("sensor_delay",), (0.705,), 1529591499),
    ("single", ("seal_stick_slip",), (0.344,), 1336476793),
    ("single", ("eccentric_load",), (0.931,), 1380919046),
    ("single", ("thermal_drift",), (0.263,), 266151302),
    ("single", ("hose_compliance",), (0.78,), 1680281682),
    ("single", ("bore_friction",), (0.293,), 143433392),
    ("single", ("seal_groove_asymmetry",), (0.958,), 1882705589),
    ("single", ("entrained_air",), (0.266,), 1653028756),
    ("single", ("orifice_flow",), (0.783,), 816456271),
    ("pair", ("seal_stick_slip", "bore_friction"), (0.239, 0.282), 1367402053),
    ("pair", ("eccentric_load", "orifice_flow"), (0.176, 0.326), 460888260),
    ("null", (), (), 2106818034),
    ("single", ("sensor_delay",), (0.204,), 1678349082),
    ("single", ("seal_stick_slip",), (0.939,), 1534696275),
    ("single", ("eccentric_load",), (0.281,), 491743066),
    ("single", ("thermal_drift",), (0.797,), 535131697),
    ("single", ("hose_compliance",), (0.191,), 1899919327),
    ("single", ("bore_friction",), (0.729,), 1492984258),
    ("single", ("seal_groove_asymmetry",), (0.231,), 337464467),
    ("single", ("entrained_air",), (0.977,), 1724918861),
    ("single", ("orifice_flow",), (0.291,), 1183631396),
    ("pair", ("thermal_drift", "eccentric_load"), (0.862, 0.853), 1213861467),
    ("pair", ("bore_friction", "entrained_air"), (0.32, 0.286), 2087483343),
    ("unexplained", ("sensor_nonlinearity",), (0.228,), 1108320853),
    ("unexplained", ("sensor_nonlinearity",), (0.761,), 76134948),
)
"""Family a's first round for seed 37, taken from the generator before family b existed."""

PLAN_DIGESTS = {
    0: "5f850e28f5e4050fcac44c542298dff761e8e87446ee463900fefedb9d9ad95d",
    37: "74b852361835261306e552bbb1f132c2a6c1662594fd94b9e5ce1b16649aee60",
    41: "950c12c9eb163d17879735d899961cf496970cb6b1fe61649ab2f84e675417f9",
}
"""SHA-256 of :func:`_plan_text` of family a's first round, before family b existed."""


def _plan_text(seed: int, family: str | None = None) -> str:
    """Kinds, effects, strengths, noise seeds, nominal rigs and drives of a round, as text."""
    if family is None:  # the stored sets' draw: the plans family a had before family b
        specs = plan_cases(26, seed, span="seed")
    else:
        specs = plan_cases(26, seed, family=family, span="seed")
    return str(
        [
            (
                s.kind,
                tuple(e.name for e in s.effects),
                tuple(round(e.strength, 3) for e in s.effects),
                s.noise_seed,
                s.nominal_key,
                s.air_driven,
            )
            for s in specs
        ]
    )


def _short_run(plain: RigRun, effects: list[Effect]) -> RigRun:
    return simulate_rig(plain.plant.rig, effects, seed_pulsing((1.38e6,), pulsing_s=0.6))


def test_family_b_has_a_law_of_its_own_for_every_library_effect_with_its_entry() -> None:
    assert tuple(EFFECTS_B) == tuple(catalogue.CATALOGUE)
    plant = base_plant(nominal_rigs()["one_washer_open"])
    for name, cls in EFFECTS_B.items():
        assert cls.entry is catalogue.entry(name)
        assert cls.name == name and cls.signature == catalogue.entry(name).signature
        assert cls is not EFFECTS[name] and not issubclass(cls, EFFECTS[name])
        assert type(cls().law(plant)) is not type(EFFECTS[name]().law(plant))
        assert "Source:" in cls.description() and len(cls.description()) > 300
        declared = [p.name for p in cls.parameters]
        assert declared[0] == "strength"
        assert sorted(declared) == sorted(f.name for f in fields(cls))
        assert all(p.unit and p.description for p in cls.parameters)
        assert cls.diagnosis_model


@pytest.mark.parametrize("name", list(EFFECTS_B))
def test_family_b_law_at_strength_zero_changes_nothing(name: str, rig_run: RunFactory) -> None:
    plain = rig_run(**SHORT)
    zero = _short_run(plain, [EFFECTS_B[name](strength=0.0)])
    assert not zero.effects
    for key in CHANNELS:
        assert np.array_equal(zero.true()[key], plain.true()[key])
        assert np.array_equal(zero.measured[key], plain.measured[key])


@pytest.mark.parametrize("name", list(EFFECTS_B))
def test_family_b_law_at_full_strength_changes_the_channels_of_its_entry(
    name: str, rig_run: RunFactory
) -> None:
    plain = rig_run(**SHORT)
    listed = catalogue.entry(name).channels
    cls = EFFECTS_B[name]
    settings: list[dict[str, str]] = [{}]
    if any(p.name == "channel" for p in cls.parameters):  # one law per channel it can reach
        settings = [{"channel": channel} for channel in listed]
    for setting in settings:
        run = _short_run(plain, [cls(strength=1.0, **setting)])  # type: ignore[arg-type]
        assert [type(e) for e in run.effects] == [cls]
        assert all(np.all(np.isfinite(v)) for v in run.true().values())
        changed = {
            key for key in CHANNELS if not np.array_equal(run.measured[key], plain.measured[key])
        }
        expected = set(setting.values()) or set(listed)
        assert expected <= changed, (setting, changed)
        if setting:
            assert changed == expected


def test_family_b_laws_take_the_rig_together_on_separate_ports(rig_run: RunFactory) -> None:
    plain = rig_run(**SHORT)
    plant = build_plant(plain.plant.rig, [cls() for cls in EFFECTS_B.values()])
    assert len(plant.laws) == len(EFFECTS_B)


def test_family_b_sensor_delay_lags_its_channel_by_the_set_delay() -> None:
    time = np.arange(0.0, 2.0, 1e-3)
    values = np.sin(2.0 * np.pi * 5.0 * time)
    for kind in ("bessel", "butterworth"):
        law = SensorDelayB(strength=0.75, channel="p_b", kind=kind).law(None)  # type: ignore[arg-type]
        delayed = law.acquisition("p_b", time, values)
        steady = time > 0.5
        ratio = np.sum(delayed[steady] * np.exp(-10j * np.pi * time[steady])) / np.sum(
            values[steady] * np.exp(-10j * np.pi * time[steady])
        )
        assert -np.angle(ratio) / (10.0 * np.pi) == pytest.approx(3.0e-3, abs=5e-5)
        assert law.acquisition("x_c", time, values) is values


def test_family_a_plans_are_those_of_before_family_b() -> None:
    plan_cases(26, 37, family="b")  # family b registers its out-of-library laws first
    specs = plan_cases(26, 37, span="seed")
    snapshot = tuple(
        (
            s.kind,
            tuple(e.name for e in s.effects),
            tuple(round(e.strength, 3) for e in s.effects),
            s.noise_seed,
        )
        for s in specs
    )
    assert snapshot == SEED_37_ROUND
    assert all(s.family == "a" for s in specs)
    assert all(type(e) is effect_class(e.name) for s in specs for e in s.effects)
    for seed, digest in PLAN_DIGESTS.items():
        text = _plan_text(seed)
        assert text == _plan_text(seed, "a")
        assert hashlib.sha256(text.encode()).hexdigest() == digest, seed


def test_family_b_plan_covers_every_effect_subtle_and_strong_in_its_first_round() -> None:
    specs = plan_cases(26, 37, family="b")
    singles = {(s.effects[0].name, s.strength_class) for s in specs if s.kind == "single"}
    assert singles == {(name, c) for name in EFFECTS_B for c in ("subtle", "strong")}
    assert sum(s.kind == "null" and not s.effects for s in specs) == 2
    assert sum(s.kind == "pair" for s in specs) == 4
    assert all(s.family == "b" for s in specs)
    library = [e for s in specs if s.kind in ("single", "pair") for e in s.effects]
    assert all(type(e) is EFFECTS_B[e.name] for e in library)
    outside = [s.effects[0] for s in specs if s.kind == "unexplained"]
    assert len(outside) == 2 and all(e.name in family_b.OUTSIDE_B for e in outside)
    assert all(e.name in OUT_OF_LIBRARY and e.name not in EFFECTS for e in outside)
    family_a = plan_cases(26, 37)
    assert [s.noise_seed for s in specs] != [s.noise_seed for s in family_a]
    drawn = [e.values() for e in library if e.name == "seal_stick_slip"]
    assert len({d["sharpness"] for d in drawn}) == len(drawn) >= 2  # its own draws vary


def test_an_unknown_family_is_refused() -> None:
    with pytest.raises(EffectError, match="family"):
        select_cases(3, 0, family="d")


def test_the_family_b_measurement_chain_is_not_an_effect_and_lags_every_channel(
    rig_run: RunFactory,
) -> None:
    plain = rig_run(**SHORT)
    run = _short_run(plain, [MeasurementChainB(noise_share=0.0)])
    assert run.effects[0].name not in catalogue.CATALOGUE
    for key in CHANNELS:
        assert np.array_equal(run.true()[key], plain.true()[key])
        assert not np.array_equal(run.measured[key], plain.measured[key])


def brake_hil(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "brake_hil.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_cases_command_writes_family_b_cases(tmp_path: Path) -> None:
    out = tmp_path / "bench"
    result = brake_hil(
        "cases", "--family", "b", "--count", "3", "--seed", "5", "--out", out,
        "--pulsing-seconds", "1", "--jobs", "2",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    document = json.loads((out / "labels.json").read_text())
    assert document["generator"]["family"] == "b"
    labels = document["cases"]
    assert sorted(labels) == ["000", "001", "002"]
    assert all(label["family"] == "b" for label in labels.values())
    assert all(label["measurement_chain"][0]["name"] == "daq_b" for label in labels.values())
    assert all("daq_b" not in label["expected_effects"] for label in labels.values())
    specs = plan_cases(3, 5, family="b")
    for spec in specs:
        assert [e["name"] for e in labels[spec.case_id]["effects"]] == [
            e.name for e in spec.effects
        ]
        assert (out / "cases" / spec.case_id / "recording" / "metadata.yaml").is_file()


def test_cases_command_refuses_an_unknown_family(tmp_path: Path) -> None:
    result = brake_hil("cases", "--family", "d", "--out", tmp_path / "bench")
    assert result.returncode == 2
    assert "--family" in result.stderr and "invalid choice" in result.stderr
    assert not (tmp_path / "bench").exists()
