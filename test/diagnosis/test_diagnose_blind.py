"""The diagnosis, blind, on a small fixed-seed set of virtual-rig recordings (CI subset).

Each case is a recording and the nominal rig file in a folder of its own; the labels are
written apart and read only by the scorer after every verdict is in. The full benchmark is
`brake-hil benchmark` (docs/diagnosis.md); this keeps a fast, fixed slice of it in CI.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
import re
import shutil

import pytest

from brake_hil.app.benchmark import read_labels, run_cases, score
from brake_hil.diagnosis.diagnose import Diagnosis, diagnose
from brake_hil.io.recording_reader import read_recording
from brake_hil.io.recording_writer import save_recording
from brake_hil.physics.rig import Rig, load_rig
from brake_hil.virtual_rig.effects import make_effect
from brake_hil.virtual_rig.excitation import seed_pulsing
from brake_hil.virtual_rig.simulator import simulate_rig
from test.conftest import CONFIG

CASES = {  # case -> (effect, strength, caliper stiffness error, valve error)
    "a": (None, 0.0, 1.12, 0.85),
    "b": ("sensor_delay", 1.0, 0.9, 1.1),
    "c": ("eccentric_load", 1.0, 1.05, 1.2),
    "d": ("entrained_air", 1.0, 0.95, 0.9),
    "e": ("sensor_nonlinearity", 1.0, 1.05, 0.9),  # out of the library: "unexplained"
}
OUT_OF_LIBRARY = {"sensor_nonlinearity"}


@pytest.fixture(scope="module")
def case_set(tmp_path_factory: pytest.TempPathFactory, default_rig: Rig) -> Path:
    root = tmp_path_factory.mktemp("blind")
    labels = {}
    for number, (case, (effect, strength, k_c, r_v)) in enumerate(CASES.items()):
        truth = dataclasses.replace(
            default_rig,
            caliper_stiffness=default_rig.caliper_stiffness * k_c,
            needle_valve_resistance=default_rig.needle_valve_resistance * r_v,
        )
        effects = [] if effect is None else [make_effect(effect, strength)]
        run = simulate_rig(
            truth, effects, seed_pulsing((1.38e6, 2.76e6), pulsing_s=3.0), seed=number
        )
        folder = root / "cases" / case
        folder.mkdir(parents=True)
        save_recording(folder / "recording", run.as_recording())
        shutil.copy(CONFIG / "rig_default.yaml", folder / "rig.yaml")
        expected = [] if effect is None else [effect]
        labels[case] = {"effects": ["unexplained"] if effect in OUT_OF_LIBRARY else expected}
    (root / "labels.json").write_text(json.dumps(labels))
    return root


def test_blind_diagnosis_names_each_effect_and_passes_the_null(case_set: Path) -> None:
    results = run_cases((case_set / "cases").iterdir())  # serial: the default
    figures = score(results, read_labels(case_set / "labels.json"))
    by_case = {r.case: r for r in results}
    assert figures["errors"] == []
    assert by_case["a"].effects == ()
    assert figures["false_positive_rate_null"] == 0.0
    assert figures["top1_accuracy_single"] == 1.0, figures["per_case"]
    assert figures["unexplained_recall"] == 1.0, figures["per_case"]
    assert figures["held_out_rms_improvement_median"] > 2.0


def test_an_unexplained_misfit_is_described_by_its_generic_form(case_set: Path) -> None:
    """The load cell's rising gain: unexplained, and what it looks like (interface.md)."""
    folder = case_set / "cases" / "e"
    result = diagnose(read_recording(folder / "recording"), load_rig(folder / "rig.yaml"))
    document = result.as_dict()
    verdict = document["verdict"]
    assert isinstance(verdict, dict) and verdict["effects"] == ["unexplained"]
    form = verdict["unexplained_form"]
    assert form["channel"] == "F_k" and form["improvement"] > 3.0, form
    assert form["form"] in ("static_map", "level_gain"), form
    assert "looks like" in verdict["explanation"]
    assert "residual" in document and "physics_checks" in document
    json.dumps(document)  # plain JSON


def _planned_case(tmp_path: Path, family: str, seed: int, number: int, *effects: str) -> Diagnosis:
    """Case ``number`` of ``brake-hil cases --family FAMILY --seed SEED`` (its effects
    ``effects``, checked), made at 5 s per segment and diagnosed."""
    from brake_hil.virtual_rig.cases import make_case, plan_cases

    spec = plan_cases(number + 1, seed, family=family, span="seed")[number]
    assert sorted(e.name for e in spec.effects) == sorted(effects)
    make_case(spec, tmp_path, pulsing_s=5.0)
    folder = tmp_path / spec.case_id
    return diagnose(read_recording(folder / "recording"), load_rig(folder / "rig.yaml"))


def test_a_load_cells_hysteresis_is_not_named_a_sensor_delay(tmp_path: Path) -> None:
    """Family b's load-cell hysteresis (out of the library) fits as a delay of a few tenths of
    a millisecond, but one that shrinks as the amplitude grows: a physics check sets the
    delay aside (a delay is a time) and the verdict does not name it
    (without the check, the case drawn here was named sensor_delay at about 0.74). With the
    caliper's force area calibrated, the delay no longer comes near here: no library effect
    is named (``unexplained``, the out-of-library truth)."""
    result = _planned_case(tmp_path, "b", 701, 24, "force_sensor_hysteresis")
    assert result.effects in (("unexplained",), ()), result.explanation
    findings = [c.finding for c in result.checks.get("sensor_delay", []) if not c.passed]
    # when the delay is checked, it is set aside by the segments check (the skew shrinks as
    # the amplitude grows) or by its rival (F_k read through a mode explains it as well)
    assert "sensor_delay" not in result.checks or any(
        "a delay is the same at every amplitude" in f or "explains it as well" in f
        for f in findings
    ), result.checks


def test_a_resonant_pressure_tap_is_not_named_a_sensor_delay(tmp_path: Path) -> None:
    """Family b's pressure tap (out of the library: p_b read through a 17 Hz mode) lags p_b
    at the pulsing's frequency, so a delay of p_b cuts the error; but p_b read through a
    lightly damped mode of its own, with the calibration refitted, explains it better, and
    the rival check sets the delay aside (without the check it would be named sensor_delay).
    A true delay of x_c is told from its mode and is still named."""
    tap = _planned_case(tmp_path, "b", 702, 51, "pressure_tap_resonance")
    assert "sensor_delay" not in tap.effects, tap.explanation
    findings = [c.finding for c in tap.checks.get("sensor_delay", []) if not c.passed]
    assert any("p_b read through a mode" in f for f in findings), tap.checks
    delay = _planned_case(tmp_path, "b", 703, 1, "sensor_delay")
    assert delay.effects == ("sensor_delay",), delay.explanation
    rivals = [c for c in delay.checks["sensor_delay"] if c.name == "rivals"]
    assert rivals and rivals[0].passed and "x_c" in rivals[0].finding, delay.checks


def test_a_tap_that_rings_too_little_to_show_is_read_through_its_mode(tmp_path: Path) -> None:
    """A subtle pressure tap (p_b read through a 36 Hz mode, damping 0.12) rings too little
    to show once p_b is delayed 3.2 ms (and the seal's damping doubled to match its 2 %
    gain); without the rival check it would be named ``sensor_delay`` at about 0.78. Read
    through a mode of its own, with the calibration refitted, p_b fits better at the tap's
    frequency and damping, and the
    delay is set aside. A true delay of p_b (a Butterworth chain, 3.4 ms) reads as
    well through a well-damped mode only, and is still named."""
    from brake_hil.diagnosis.candidates.resonant_reading import LIGHT_DAMPING

    tap = _planned_case(tmp_path, "b", 901, 24, "pressure_tap_resonance")
    assert "sensor_delay" not in tap.effects, tap.explanation
    reading = [c for c in tap.checks["sensor_delay"] if c.name == "rivals"]
    assert reading and not reading[0].passed, tap.checks
    found = re.search(r"mode \((\d+) Hz, damping ratio ([\d.]+)\)", reading[0].finding)
    assert found is not None, reading[0].finding
    assert 30 <= int(found[1]) <= 42 and float(found[2]) < LIGHT_DAMPING  # drawn: 35.6, 0.117
    delay = _planned_case(tmp_path, "b", 901, 7, "sensor_delay")
    assert delay.effects == ("sensor_delay",), delay.explanation
    reading = [c for c in delay.checks["sensor_delay"] if c.name == "rivals"]
    assert reading and reading[0].passed and "p_b" in reading[0].finding, delay.checks
    # The tap is out of the library: "unexplained", or, since the calibration's priors carry
    # every rig tolerance, a library stand-in that the posterior itself all but rules out
    # ("unexplained" next by the posterior): never a sure wrong name.
    assert tap.residual is not None
    if tap.effects == ("unexplained",):
        assert tap.residual.summary.startswith("unexplained;")
    else:
        assert tap.confidence < 0.9, tap.explanation
        assert "next by the posterior, unexplained" in tap.explanation, tap.explanation
    assert delay.residual is not None
    assert delay.residual.summary.startswith("the calibrated LTI baseline's misfit;")


def test_a_late_master_cylinder_pressure_is_not_named_a_hose(tmp_path: Path) -> None:
    """A ``p_i`` acquired 4 ms late (a pure delay and a first-order filter) makes every
    output lead the prediction alike; a creeping hose with a calibration of less lag of its
    own fits it better than a pure delay does (without the rival check it would be named
    ``hose_compliance`` at about 0.92). Fitted in the hose's place, every output led alike
    explains it as well: the hose is set aside (a hose adds lag, it cannot make the outputs
    lead). A true hose leaves a late ``p_i`` no room and is still named."""
    late = _planned_case(tmp_path, "a", 901, 14, "sensor_delay")
    assert "hose_compliance" not in late.effects, late.explanation
    rivals = [c for c in late.checks["hose_compliance"] if c.name == "rivals"]
    assert rivals and not rivals[0].passed and "p_i acquired" in rivals[0].finding, late.checks
    hose = _planned_case(tmp_path, "a", 901, 3, "hose_compliance")
    assert hose.effects == ("hose_compliance",), hose.explanation
    rivals = [c for c in hose.checks["hose_compliance"] if c.name == "rivals"]
    assert rivals and rivals[0].passed, hose.checks


def test_a_family_b_hose_on_the_restricted_rig_is_told_from_a_late_input(tmp_path: Path) -> None:
    """A strong creeping hose behind the restricted valve: the wall's swell does not change
    with pressure (a node compliance scaled by each segment's ``C_b``, which the air makes
    fall with pressure, would leave 6.6 times the noise, and a late ``p_i`` fits better).
    With the wall's compliance fixed the hose leaves 1.6 times the noise, and a late ``p_i``
    fitted in its place (read past the window's end) 1.68 times that: told apart at 1.5, the
    hose is named. A true late ``p_i`` on that rig (a late ``p_i`` leaves 1.11 times the
    hose's error) is not named a hose."""
    hose = _planned_case(tmp_path, "b", 1701, 252, "hose_compliance")
    assert hose.effects == ("hose_compliance",), hose.explanation
    rivals = [c for c in hose.checks["hose_compliance"] if c.name == "rivals"]
    assert rivals and rivals[0].passed, hose.checks
    late = _planned_case(tmp_path, "b", 1601, 174, "sensor_delay")
    assert "hose_compliance" not in late.effects, late.explanation
    rivals = [c for c in late.checks["hose_compliance"] if c.name == "rivals"]
    assert rivals and not rivals[0].passed and "p_i acquired" in rivals[0].finding, late.checks


def test_a_delay_beside_a_hose_is_named_but_not_sure(tmp_path: Path) -> None:
    """A creeping hose beside a late ``p_b``: the delay alone leaves 2 times the noise, so
    the pair can never be named, and ``sensor_delay`` is the verdict. Its fitted delays are
    a skew of ``p_b`` and a common lag of ``F_k`` and ``x_c`` (the hose's), which no one late
    channel makes: still named, doubted in words and less sure, and the explanation says
    what is beside it. A true late ``F_k`` stays surer, undoubted."""
    from brake_hil.diagnosis.verdict import NOT_ALONE
    from brake_hil.report.diagnosis_report import write_report

    both = _planned_case(tmp_path, "b", 1001, 49, "hose_compliance", "sensor_delay")
    assert both.effects == ("sensor_delay",), both.explanation
    assert both.confidence_capped == NOT_ALONE
    assert "skew of p_b" in both.summary.not_alone["sensor_delay"]
    assert "Not sure it is alone" in both.explanation and "a hose" in both.explanation
    page = write_report(both, tmp_path / "report").read_text()
    assert "not sure it is alone" in page and "what else is there: its delays are a skew" in page
    verdict = both.as_dict()["verdict"]
    assert isinstance(verdict, dict) and "skew of p_b" in verdict["not_sure_alone"]
    assert "possible_second_effect" not in verdict  # its own values say so, not a pair
    alone = _planned_case(tmp_path, "b", 1001, 14, "sensor_delay")
    assert alone.effects == ("sensor_delay",), alone.explanation
    assert alone.confidence_capped is None and alone.confidence > both.confidence + 0.2
    assert "sensor_delay" not in alone.summary.not_alone
    assert "not_sure_alone" not in alone.as_dict()["verdict"]


def test_an_eccentric_loads_seating_share_is_followed_over_the_pressures(tmp_path: Path) -> None:
    """Family a's eccentric load seats hyperbolically (``F_0 / (F_0 + F)``); a share linear
    in ``p_b`` leaves ``x_c`` about 5 times better than the baseline (NRMSE); to second order
    in ``p_b`` (``share_curvature``) it follows the seating over the recorded pressures, more
    than 10 times better."""
    result = _planned_case(tmp_path, "a", 1001, 1, "eccentric_load")
    assert result.effects == ("eccentric_load",), result.explanation
    before, after = (
        result.baseline_metrics["x_c"]["nrmse"],
        result.improved_metrics["x_c"]["nrmse"],
    )
    assert before / after > 10.0, (before, after)
    share = result.improved.parameters()
    assert share["share_curvature"] < 0 < share["share_slope"]  # rising, levelling off


def test_a_subtle_second_effect_under_a_strong_one_leaves_the_verdict_unsure(
    tmp_path: Path,
) -> None:
    """An eccentric load with a little entrained air: the eccentric load alone cuts the
    error so much that a pair with it can never be named (``PAIR_SHARE``); unfitted, those
    pairs would leave the verdict at 0.90. Fitted after all, the pair with the air cuts what
    the eccentric load leaves 2.7 times: the eccentric load is still named, doubted, and the
    verdict names the effect beside it: the air's signature, even harmonics of
    ``p_b`` beyond their scatter and the noise, is seen though ``p_b`` misses by under 1 %;
    the pairs stay charged as unnameable."""
    import dataclasses

    from brake_hil.diagnosis.verdict import decide

    result = _planned_case(tmp_path, "a", 1501, 244, "eccentric_load", "entrained_air")
    assert result.effects == ("eccentric_load",), result.explanation
    unpaired = decide(dataclasses.replace(result.summary, pairs=()))
    assert result.confidence < unpaired.confidence - 0.2, result.explanation
    assert "Not sure it is alone" in result.explanation
    assert ("eccentric_load", "entrained_air") in result.summary.pairs_ruled_out
    assert ("eccentric_load", "entrained_air") in {p.effects for p in result.summary.pairs}
    verdict = result.as_dict()["verdict"]
    assert isinstance(verdict, dict)
    # the air's signature is judged against the noise, not a bore pressure off by over 1 %:
    # its physics checks pass, so the second effect is named beside the eccentric load
    assert verdict.get("possible_second_effect") == "entrained_air", verdict
    assert "with entrained_air beside it" in str(verdict["not_sure_alone"])
    assert "Not sure it is alone: with entrained_air beside it" in result.explanation


def test_a_hose_a_late_input_ties_with_is_named_doubted_and_both_are_checked(
    tmp_path: Path,
) -> None:
    """Family b's strong creeping hose, case 035 of seed 8402 (every rig value within its
    tolerance): a late ``p_i`` fitted in the hose's place leaves 1.43 times its error, under
    the 1.5 that tells them apart, and the delay itself fails its segments check. The hose
    was dropped and the verdict none at 0.05; now it is named, doubted as not told apart
    from ``sensor_delay``, and the report's checks name both the hose and the DAQ."""
    from brake_hil.diagnosis.ties import NOT_TOLD_APART
    from brake_hil.report.diagnosis_report import write_report
    from brake_hil.virtual_rig.cases import make_case, plan_cases

    spec = plan_cases(56, 8402, family="b")[35]
    assert [e.name for e in spec.effects] == ["hose_compliance"]
    make_case(spec, tmp_path, pulsing_s=5.0)
    folder = tmp_path / spec.case_id
    result = diagnose(read_recording(folder / "recording"), load_rig(folder / "rig.yaml"))
    assert result.effects == ("hose_compliance",), result.explanation
    assert result.confidence_capped == NOT_TOLD_APART and result.confidence < 0.5
    assert result.summary.not_told_from == {"hose_compliance": "sensor_delay"}
    assert "Not told apart from sensor_delay: p_i acquired" in result.explanation
    page = write_report(result, tmp_path / "out").read_text()
    checks = page[page.index("<b>What to check on the rig:</b>") :]
    assert "the hose: its type, length and age" in checks
    assert "not told apart from it: the DAQ channel of the late sensor" in checks
