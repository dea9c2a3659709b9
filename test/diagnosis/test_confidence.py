"""The verdict's confidence follows the evidence; a rule's doubt is said in words beside it.

Fixtures (``data/*.summary.json``) are the decision inputs (``diagnosis.json``:
``decision_inputs``) of two stored diagnoses: a weak wearing seal of the virtual lab
(``brake-hil fleet``, rig-1 run 1: stick-slip strength 0.1, no other effect, where a pair
with an unseen sensor delay cuts what the seal leaves 1.48 times), and an eccentric load
with a groove asymmetry of the benchmark set (``brake-hil cases --seed 3131``, case 010:
the pair with the groove asymmetry cuts what the eccentric load leaves 5.8 times, but the
groove's signature is not in the evidence).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
import re

import pytest

from brake_hil.diagnosis.summary import Hypothesis, Summary
from brake_hil.diagnosis.verdict import NOT_ALONE, SET_ASIDE, decide

DATA = Path(__file__).parent / "data"


def stored(name: str) -> Summary:
    return Summary.from_dict(json.loads((DATA / f"{name}.summary.json").read_text()))


def with_single(summary: Summary, name: str, **changes: object) -> Summary:
    singles = tuple(
        dataclasses.replace(h, **changes) if h.effects == (name,) else h for h in summary.singles
    )
    return dataclasses.replace(summary, singles=singles)


def test_the_confidence_of_a_doubted_single_follows_how_much_the_pair_cuts() -> None:
    """A weak doubt (a pair cutting the single's leftover 1.48 times) and a strong one (5.8
    times) differ, the stronger doubt the less sure, each under the same single with no
    pair fitted beside it."""
    weak, strong = decide(stored("lab_seal_weak")), decide(stored("eccentric_groove"))
    assert weak.effects == ("seal_stick_slip",) and strong.effects == ("eccentric_load",)
    assert weak.capped is None and strong.capped is None  # measured, not said in words
    assert strong.confidence < weak.confidence - 0.2
    # the same recordings with the pairs' doubt taken away are surer
    alone = dataclasses.replace(stored("eccentric_groove"), pairs=())
    assert decide(alone).effects == ("eccentric_load",)
    assert decide(alone).confidence > strong.confidence + 0.2
    lone_seal = decide(dataclasses.replace(stored("lab_seal_weak"), pairs=()))
    assert lone_seal.confidence >= weak.confidence
    # and the confidence moves with the pair's cut, never stuck at one value
    summary = stored("lab_seal_weak")
    seal = next(h for h in summary.singles if h.effects == ("seal_stick_slip",))
    seen = []
    for cut in (1.6, 2.5, 4.0):
        pair = Hypothesis(
            ("seal_stick_slip", "sensor_delay"),
            6,
            seal.held_out_cost / cut,
            (seal.held_out_cost / cut,) * 3,
            True,
            False,
        )
        seen.append(decide(dataclasses.replace(summary, pairs=(pair,))).confidence)
    assert seen[0] > seen[1] > seen[2]


def with_pair_cut(summary: Summary, cut: float) -> Summary:
    """The lab's seal with its pairs cutting what it leaves ``cut`` times (a second effect)."""
    seal = next(h for h in summary.singles if h.effects == ("seal_stick_slip",))
    pairs = tuple(
        dataclasses.replace(p, held_out_cost=seal.held_out_cost / cut) if p.plausible else p
        for p in summary.pairs
        if "seal_stick_slip" in p.effects
    )
    return dataclasses.replace(summary, pairs=pairs)


def test_a_second_effect_failing_its_physics_checks_is_not_named() -> None:
    """The lab's seal, with no other effect in the simulation: the best pair (an unseen
    sensor delay) cuts what it leaves 1.48 times, less than its three more parameters
    cost (the posterior keeps the single), so no second effect is said. Where a pair cuts
    it 4 times, the pair's posterior wins: a second effect is likely, not identified while
    the delay's signature is not in the evidence; with it seen, the delay is named."""
    lab = stored("lab_seal_weak")
    assert (
        lab.doubt(("seal_stick_slip",)) is None and lab.hidden_partner("seal_stick_slip") is None
    )
    summary = with_pair_cut(lab, 4.0)
    delay = next(h for h in summary.singles if h.effects == ("sensor_delay",))
    assert not delay.consistent
    doubt = summary.doubt(("seal_stick_slip",)) or ""
    assert "a second effect is likely; not identified" in doubt
    assert "sensor_delay" not in doubt
    partner = summary.hidden_partner("seal_stick_slip")
    assert partner is not None and partner[0] is None and partner[1] == pytest.approx(4.0)
    # seen, but its own fit alone is a lag of the line, not a delay (not_alone): not named
    shown = with_single(summary, "sensor_delay", consistent=True)
    assert "sensor_delay" in shown.not_alone
    assert shown.hidden_partner("seal_stick_slip")[0] is None  # type: ignore[index]
    seen = dataclasses.replace(shown, not_alone={})
    assert seen.hidden_partner("seal_stick_slip")[0] is not None  # type: ignore[index]
    assert "beside it the fit leaves" in (seen.doubt(("seal_stick_slip",)) or "")
    # the benchmark's groove asymmetry is not seen either: not named beside the eccentric load
    groove = stored("eccentric_groove")
    assert groove.hidden_partner("eccentric_load")[0] is None  # type: ignore[index]
    # a partner whose pair fits unphysical values is not named even when its signature is seen
    implausible = dataclasses.replace(
        seen, pairs=tuple(dataclasses.replace(p, plausible=False) for p in seen.pairs)
    )
    assert implausible.hidden_partner("seal_stick_slip") is None


def test_a_doubted_verdict_says_its_doubt_in_words_beside_its_number() -> None:
    """A single whose own fitted values say it is not alone, and a verdict replacing one set
    aside by a physics check: the doubt is said in words beside the confidence, which is
    how often doubted verdicts were right, under the same verdict undoubted."""
    summary = stored("lab_seal_weak")
    measured = decide(summary)
    assert re.fullmatch(r"0\.\d\d", measured.confidence_text())
    not_alone = dataclasses.replace(
        summary, pairs=(), not_alone={"seal_stick_slip": "a second physics"}
    )
    capped = decide(not_alone)
    assert capped.effects == ("seal_stick_slip",) and capped.capped == NOT_ALONE
    assert re.fullmatch(r"0\.\d\d, not sure it is alone", capped.confidence_text())
    assert capped.confidence < decide(dataclasses.replace(summary, pairs=())).confidence - 0.2
    set_aside = dataclasses.replace(
        stored("eccentric_groove"), stand_ins={"eccentric_load": "differs between segments"}
    )
    replaced = decide(set_aside)
    assert replaced.capped == SET_ASIDE and "eccentric_load" not in replaced.effects
    assert replaced.confidence_text().endswith(SET_ASIDE)
    # still a pure function of the stored summary
    again = Summary.from_dict(json.loads(json.dumps(not_alone.as_dict())))
    assert decide(again) == capped
