"""The confidence: a verdict's traits, the logistic read of them, and the fit of its weights."""

from __future__ import annotations

import math
from pathlib import Path
import sys

import numpy as np
import pytest

from brake_hil.diagnosis.reliability import (
    CAPPED_LOG_ODDS,
    KIND_LOG_ODDS,
    LEAD_LIMITS,
    LEAD_LOG_ODDS,
    VerdictTraits,
    reliability,
    traits,
)
from brake_hil.diagnosis.summary import Hypothesis, Summary
from brake_hil.diagnosis.verdict import NOT_ALONE, decide
from test.diagnosis.test_decide import BASE, summary


def fitted(cut: float, *effects: str) -> Hypothesis:
    return Hypothesis(effects, len(effects), BASE / cut, (BASE / cut,) * 3, True, True)


def test_the_lead_is_the_verdicts_cut_over_its_best_rival_sharing_no_effect() -> None:
    s = summary(
        fitted(10.0, "orifice_flow"),
        fitted(5.0, "thermal_drift"),
        fitted(15.0, "orifice_flow", "thermal_drift"),  # shares an effect: no rival
        fitted(2.0, "entrained_air", "thermal_drift"),
    )
    s = Summary(**{**s.__dict__, "form_gain": 3.0})
    single = traits(s, ("orifice_flow",), False, margin=math.inf)
    assert single.kind == "single" and single.lead == pytest.approx(math.log(10.0 / 5.0))
    pair = traits(s, ("orifice_flow", "thermal_drift"), False, margin=math.inf)
    assert pair.kind == "pair" and pair.lead == pytest.approx(math.log(15.0 / 1.0))
    none = traits(s, (), False)
    assert none.kind == "none" and none.lead == pytest.approx(-math.log(15.0))
    unexplained = traits(s, ("unexplained",), True)
    assert unexplained.kind == "unexplained" and unexplained.capped
    assert unexplained.lead == pytest.approx(math.log(3.0 / 15.0))
    # a named verdict's lead is no more than its smallest decision margin
    assert traits(s, ("orifice_flow",), False, margin=0.5).lead == pytest.approx(0.5)
    # and it is held within the fitted range
    far = summary(fitted(1e6, "orifice_flow"))
    assert traits(far, ("orifice_flow",), False, margin=math.inf).lead == LEAD_LIMITS[1]
    assert traits(far, (), False).lead == LEAD_LIMITS[0]


def test_the_confidence_is_a_probability_that_grows_with_the_lead() -> None:
    leads = np.linspace(LEAD_LIMITS[0], LEAD_LIMITS[1], 9)
    for kind in KIND_LOG_ODDS:
        seen = [reliability(VerdictTraits(kind, float(lead), False)) for lead in leads]
        assert all(0.0 < p < 1.0 for p in seen)
        assert seen == sorted(seen) and seen[-1] > seen[0] + 0.3
        doubted = [reliability(VerdictTraits(kind, float(lead), True)) for lead in leads]
        assert all(d < p for d, p in zip(doubted, seen))
    one = VerdictTraits("single", 1.0, False)
    z = KIND_LOG_ODDS["single"] + LEAD_LOG_ODDS
    assert reliability(one) == pytest.approx(1.0 / (1.0 + math.exp(-z)))
    z += CAPPED_LOG_ODDS
    assert reliability(VerdictTraits("single", 1.0, True)) == pytest.approx(1 / (1 + math.exp(-z)))


def test_a_verdict_carries_the_confidence_of_its_traits() -> None:
    s = summary(fitted(40.0, "orifice_flow"), fitted(5.0, "thermal_drift"))
    verdict = decide(s)
    assert verdict.effects == ("orifice_flow",)
    assert verdict.confidence == reliability(traits(s, verdict.effects, False, verdict.margin))
    doubted = decide(Summary(**{**s.__dict__, "not_alone": {"orifice_flow": "two lags"}}))
    assert doubted.capped == NOT_ALONE
    assert doubted.confidence < verdict.confidence


def test_the_weights_fitted_by_the_benchmark_recover_a_known_law() -> None:
    """Right and wrong verdicts drawn from a logistic of known weights: the benchmark's fit
    (``benchmarks/bench_confidence.py``) finds them again, and its confidences then match
    how often the drawn verdicts were right."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    import bench_confidence

    rng = np.random.default_rng(7)
    truth = {"none": -0.5, "unexplained": 0.3, "single": 1.2, "pair": -1.0}
    lead_weight, capped_weight = 0.6, -1.5
    cases = []
    for _ in range(4000):
        kind = str(rng.choice(list(truth)))
        t = VerdictTraits(kind, float(rng.uniform(-3.0, 5.0)), bool(rng.random() < 0.3))
        p = reliability(t, truth, lead_weight, capped_weight)
        cases.append((t, bool(rng.random() < p)))
    weights = bench_confidence.fit(cases)
    expected = [*truth.values(), lead_weight, capped_weight]
    assert np.allclose(weights, expected, atol=0.25), weights
    rows = bench_confidence.scored(cases, weights)
    for low, high in ((0.1, 0.3), (0.4, 0.6), (0.7, 0.9)):
        inside = [ok for p, ok in rows if low <= p < high]
        assert len(inside) > 100 and low - 0.05 <= float(np.mean(inside)) <= high + 0.05


def test_off_steady_pulsing_the_confidence_says_it_was_not_fitted_there() -> None:
    """The weights were fitted on steady pulsing: on a sweep, a ramp or a procedure the same
    verdict is said with that doubt, and less sure; the flag replays through JSON, and a
    summary stored without it is steady pulsing, as every earlier one was."""
    import dataclasses
    import json

    from brake_hil.diagnosis.verdict import OFF_PULSING

    s = summary(fitted(40.0, "orifice_flow"), fitted(5.0, "thermal_drift"))
    off = dataclasses.replace(s, steady=False)
    assert decide(off).effects == decide(s).effects
    assert decide(off).capped == OFF_PULSING and decide(s).capped is None
    assert decide(off).confidence < decide(s).confidence - 0.2
    assert decide(Summary.from_dict(json.loads(json.dumps(off.as_dict())))) == decide(off)
    stored = {k: v for k, v in s.as_dict().items() if k != "steady"}
    assert Summary.from_dict(stored).steady
    quiet = dataclasses.replace(summary(fitted(1.1, "orifice_flow")), noise_cost=BASE / 2)
    nothing = dataclasses.replace(quiet, steady=False)  # none under the noise floor
    assert decide(nothing).effects == () and decide(nothing).capped == OFF_PULSING
