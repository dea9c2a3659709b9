"""The concealed-effect benchmark: labelled cases, labels kept apart from the recordings."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from brake_hil.app.cases import CaseOptions, generate_cases
from brake_hil.io.recording_reader import read_recording
from brake_hil.physics.rig import load_rig
from brake_hil.virtual_rig import EFFECTS
from brake_hil.virtual_rig.cases import (
    SEED_DRIVE,
    STRONG_STRENGTHS,
    SUBTLE_STRENGTHS,
    CaseDrive,
    case_excitation,
    label,
    nominal_rigs,
    plan_cases,
    select_cases,
    truth_rig,
)
from brake_hil.virtual_rig.draws import PERTURBED_KEYS
from brake_hil.virtual_rig.effects import OUT_OF_LIBRARY
from brake_hil.virtual_rig.rig_yaml import rig_to_mapping


def test_the_first_round_covers_null_cases_every_effect_both_strengths_and_pairs() -> None:
    specs = plan_cases(26, seed=3)
    singles = {(s.effects[0].name, s.strength_class) for s in specs if s.kind == "single"}
    assert singles == {(name, c) for name in EFFECTS for c in ("subtle", "strong")}
    assert sum(s.kind == "null" and not s.effects for s in specs) == 2
    pairs = [s for s in specs if s.kind == "pair"]
    assert len(pairs) == 4
    assert all(len({e.name for e in s.effects}) == 2 for s in pairs)
    outside = [s for s in specs if s.kind == "unexplained"]
    assert sorted(s.strength_class for s in outside) == ["strong", "subtle"]
    assert all(s.effects[0].name in OUT_OF_LIBRARY for s in outside)


def test_strengths_fall_in_their_class() -> None:
    for spec in plan_cases(48, seed=5):
        for effect in spec.effects:
            low, high = SUBTLE_STRENGTHS if effect.strength < 0.5 else STRONG_STRENGTHS
            assert low <= effect.strength <= high
        if spec.kind == "single":
            expected = SUBTLE_STRENGTHS if spec.strength_class == "subtle" else STRONG_STRENGTHS
            assert expected[0] <= spec.effects[0].strength <= expected[1]


def test_parameter_errors_stay_within_one_sigma_of_the_rig_tolerances() -> None:
    rigs = nominal_rigs()
    largest = dict.fromkeys(PERTURBED_KEYS, 0.0)
    for spec in plan_cases(60, seed=11, span="seed"):  # the stored sets' draw
        nominal = rigs[spec.nominal_key]
        assert set(spec.parameter_errors) == set(PERTURBED_KEYS)
        for key, error in spec.parameter_errors.items():
            assert abs(error) <= nominal.tolerance(key) + 1e-12, key
            largest[key] = max(largest[key], abs(error) / nominal.tolerance(key))
        truth = truth_rig(nominal, spec.parameter_errors, "truth")
        ratio = truth.caliper_stiffness / nominal.caliper_stiffness - 1.0
        assert ratio == pytest.approx(spec.parameter_errors["caliper.stiffness"], abs=1e-12)
        assert truth.piston_diameter == nominal.piston_diameter
    assert min(largest.values()) > 0.5  # the draws use the tolerance, not a sliver of it


def test_a_case_does_not_depend_on_how_many_are_generated() -> None:
    few, many = plan_cases(6, seed=2), plan_cases(30, seed=2)
    assert [(s.kind, s.effects, s.parameter_errors) for s in few] == [
        (s.kind, s.effects, s.parameter_errors) for s in many[:6]
    ]
    assert plan_cases(6, seed=3)[1].effects != few[1].effects


def test_generated_cases_keep_their_labels_apart(tmp_path: Path) -> None:
    labels_path = generate_cases(tmp_path / "bench", 2, 4, CaseOptions(pulsing_s=0.4))
    assert labels_path == tmp_path / "bench" / "labels.json"
    cases = sorted(p.name for p in (tmp_path / "bench" / "cases").iterdir())
    assert cases == ["000", "001"]
    labels = json.loads(labels_path.read_text())["cases"]
    for case in cases:
        folder = tmp_path / "bench" / "cases" / case
        assert sorted(p.name for p in folder.iterdir()) == ["recording", "rig.yaml"]
        label = labels[case]
        nominal = nominal_rigs()[label["nominal_rig"]]
        expected = rig_to_mapping(nominal)["rig"]
        if label.get("air") == "degassed":  # a degassed null: its rig file says so
            expected["fluid"]["air_fraction"] = 1e-6
            expected["name"] += ", degassed"
        assert rig_to_mapping(load_rig(folder / "rig.yaml"))["rig"] == expected
        recording = read_recording(folder / "recording")
        assert recording.time.size == 3 * 1400
        assert label["expected_effects"] == sorted(e["name"] for e in label["effects"])
        assert label["truth_rig"]["rig"]["caliper"]["stiffness"] != nominal.caliper_stiffness
    assert labels["000"]["kind"] == "null" and labels["000"]["expected_effects"] == []
    with pytest.raises(FileExistsError):
        generate_cases(tmp_path / "bench", 1, 4, CaseOptions(pulsing_s=0.4))


def test_a_set_driven_at_another_frequency_and_pressures(tmp_path: Path) -> None:
    """``--excitation-hz 8 --max-pressures 1.0,1.8``.

    The rig file, the labels and the recording all pulse at 8 Hz, one segment per pressure.
    """
    drive = CaseDrive(8.0, (1.0e6, 1.8e6))
    labels_path = generate_cases(tmp_path / "bench", 1, 4, CaseOptions(pulsing_s=2.0, drive=drive))
    document = json.loads(labels_path.read_text())
    assert document["generator"]["excitation_hz"] == 8.0
    assert document["generator"]["max_pressures_mpa"] == [1.0, 1.8]
    folder = tmp_path / "bench" / "cases" / "000"
    assert load_rig(folder / "rig.yaml").excitation_hz == 8.0
    recording = read_recording(folder / "recording")
    pressure = recording.master_cylinder_pressure
    steady = pressure[recording.time > recording.time[-1] - 1.5]  # in the last segment
    spectrum = np.abs(np.fft.rfft(steady - steady.mean()))
    frequencies = np.fft.rfftfreq(steady.size, 1.0 / recording.sample_rate)
    assert frequencies[np.argmax(spectrum)] == pytest.approx(8.0, abs=0.7)
    assert np.max(pressure) == pytest.approx(1.8e6, rel=0.1)
    assert SEED_DRIVE.as_dict(5.0) == {
        "excitation_hz": 5.0,
        "max_pressures_mpa": [1.38, 2.07, 2.76],
    }


def test_an_out_of_library_case_is_labelled_unexplained() -> None:
    spec = next(s for s in plan_cases(26, seed=3) if s.kind == "unexplained")
    nominal = nominal_rigs()[spec.nominal_key]
    truth = truth_rig(nominal, spec.parameter_errors, "truth")
    document = label(spec, truth, case_excitation(spec, truth, 1.0))
    assert document["expected_effects"] == ["unexplained"]
    assert document["effects"][0]["name"] == "sensor_nonlinearity"


def test_a_selection_by_kind_keeps_the_cases_of_the_full_schedule() -> None:
    nulls = select_cases(5, seed=3, kinds=("null",))
    assert len(nulls) == 5 and all(s.kind == "null" and not s.effects for s in nulls)
    full = {s.number: s for s in plan_cases(max(s.number for s in nulls) + 1, seed=3)}
    assert all(full[s.number] == s for s in nulls)
    assert select_cases(4, seed=3) == plan_cases(4, seed=3)


def _files(folder: Path) -> dict[str, bytes]:
    return {
        str(path.relative_to(folder)): path.read_bytes()
        for path in sorted(folder.rglob("*"))
        if path.is_file()
    }


def test_the_default_excitation_makes_exactly_the_pulsing_cases(tmp_path: Path) -> None:
    """``--excitation pulsing`` (the default): the same seeds give the same files."""
    spec = plan_cases(3, seed=7)[1]
    truth = nominal_rigs()[spec.nominal_key]
    default = case_excitation(spec, truth, 0.4)
    named = case_excitation(spec, truth, 0.4, kind="pulsing")
    np.testing.assert_array_equal(default.pressure, named.pressure)
    assert default.label == named.label and "procedure" not in default.label
    made = []
    for name, options in (
        ("default", CaseOptions(pulsing_s=0.4)),
        ("pulsing", CaseOptions(pulsing_s=0.4, drive=CaseDrive(excitation="pulsing"))),
    ):
        labels = json.loads(generate_cases(tmp_path / name, 2, 7, options).read_text())
        for case in labels["cases"].values():
            assert "excitation_kind" not in case
            case.pop("simulation_seconds")  # wall time
        assert "excitation" not in labels["generator"]  # labels as they always were
        made.append((_files(tmp_path / name / "cases"), labels))
    assert made[0] == made[1]


def test_procedure_cases_record_their_excitation(tmp_path: Path) -> None:
    drive = CaseDrive(excitation="procedure")
    labels_path = generate_cases(tmp_path / "bench", 1, 4, CaseOptions(pulsing_s=0.5, drive=drive))
    document = json.loads(labels_path.read_text())
    assert document["generator"]["excitation"] == "procedure"
    case = document["cases"]["000"]
    assert case["excitation_kind"] == "procedure"
    assert case["excitation"].startswith("procedure: pulsing 5 Hz")
    recording = read_recording(tmp_path / "bench" / "cases" / "000" / "recording")
    pulsing_only = 3 * 1500  # 1 s ramp and 0.5 s of pulsing per pressure
    assert recording.time.size > 3 * pulsing_only


@pytest.mark.parametrize("family", ["b", "c"])
def test_every_family_takes_another_excitation(tmp_path: Path, family: str) -> None:
    drive = CaseDrive(excitation="ramp")
    options = CaseOptions(pulsing_s=0.5, drive=drive, family=family)
    labels = json.loads(generate_cases(tmp_path / "bench", 1, 5, options).read_text())
    case = labels["cases"]["000"]
    assert case["family"] == family and case["excitation_kind"] == "ramp"
    assert case["excitation"].startswith("ramp to 2.76 MPa")
    recording = read_recording(tmp_path / "bench" / "cases" / "000" / "recording")
    assert recording.time.size == 8001  # the ramp's 8 s, not 3 pulsing segments
    assert np.max(recording.master_cylinder_pressure) == pytest.approx(2.76e6, rel=0.05)
