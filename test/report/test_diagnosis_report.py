"""The report's words: rig values far off, identified parameters, why a row is not the verdict."""

from __future__ import annotations

import math

from brake_hil.diagnosis.diagnose import Hypothesis, decide, hypothesis_note
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.report.diagnosis_report import FLAG_SIGMA, RIG_CHECKS, Finding, findings, identified
from test.diagnosis.test_decide import BASE, pair, single, summary


def test_a_rig_value_far_outside_its_tolerance_is_said_in_words() -> None:
    sigmas = {"caliper_stiffness": 0.01, "valve_resistance": 0.4}
    found = findings({"caliper_stiffness": 0.9, "valve_resistance": 1.2}, sigmas)
    assert [f.name for f in found] == ["caliper_stiffness"]  # 1.2 is 0.5 sigma: no finding
    words = found[0].words
    assert words.startswith("caliper stiffness in the rig file looks 11 % high")
    assert "10.5 sigma" in words
    low = Finding("valve_resistance", 1.5, math.log(1.5) / 0.1)
    assert "needle-valve resistance in the rig file looks 33 % low" in low.words
    edge = findings({"caliper_stiffness": math.exp(0.99 * FLAG_SIGMA * 0.01)}, sigmas)
    assert edge == []


def test_every_effect_says_what_to_check_on_the_rig() -> None:
    assert set(RIG_CHECKS) == set(CATALOGUE)


def test_a_parameter_is_identified_when_its_sigma_is_under_half_its_value() -> None:
    assert identified(222.4, 41.0)
    assert not identified(0.8998, 140.0)  # the wall of text the issue showed
    assert not identified(1.0, math.nan)
    assert not identified(-2.0, 1.5)


def test_why_a_pair_above_the_verdict_is_not_it_pair_rule() -> None:
    a, b = single("entrained_air", BASE / 10), single("thermal_drift", BASE / 1.1)
    both = pair("entrained_air", "thermal_drift", BASE / 12)
    inputs = summary(a, b, both)
    verdict = decide(inputs)
    assert verdict.effects == ("entrained_air",)
    assert hypothesis_note(inputs, ("entrained_air",), verdict) == "the verdict"
    note = hypothesis_note(inputs, both.effects, verdict)
    assert note.startswith("not named (pair rule)")
    assert "cuts it 1.20 times" in note
    weak = hypothesis_note(inputs, ("thermal_drift",), verdict)
    assert "under the 1.5 required" in weak


def test_why_a_better_fit_with_more_parameters_is_not_the_verdict_parameter_penalty() -> None:
    simple = single("orifice_flow", BASE / 50)
    rich = Hypothesis(("thermal_drift",), 5, BASE / 52, (BASE / 52,) * 3, True, True)
    inputs = summary(simple, rich)
    verdict = decide(inputs)
    assert verdict.effects == ("orifice_flow",)
    note = hypothesis_note(inputs, ("thermal_drift",), verdict)
    assert note.startswith("not named (parameter penalty): 5 fitted parameters against 1")
