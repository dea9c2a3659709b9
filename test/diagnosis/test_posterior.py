"""The posterior over the fitted hypotheses, and the verdict's confidence taken from it."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
import re

import pytest

from brake_hil.diagnosis.posterior import NONE, UNEXPLAINED, log_evidence, posterior
from brake_hil.diagnosis.summary import Hypothesis, Summary
from brake_hil.diagnosis.verdict import NOT_ALONE, decide

BASE = 1.0e-5
DATA = Path(__file__).parent / "data"


def single(name: str, cost: float, parameters: int = 2, plausible: bool = True) -> Hypothesis:
    return Hypothesis((name,), parameters, cost, (cost,) * 3, plausible, True)


def pair(a: str, b: str, cost: float, parameters: int = 4) -> Hypothesis:
    return Hypothesis((a, b), parameters, cost, (cost,) * 3, True, True)


def summary(*hypotheses: Hypothesis, noise: float = BASE / 1000) -> Summary:
    return Summary(
        baseline_cost=BASE,
        baseline_window_costs=(BASE,) * 3,
        baseline_rms=BASE**0.5,
        noise_cost=noise,
        singles=tuple(h for h in hypotheses if len(h.effects) == 1),
        pairs=tuple(h for h in hypotheses if len(h.effects) == 2),
    )


def test_the_shares_are_probabilities_that_sum_to_one() -> None:
    """Every hypothesis, none and unexplained included, gets a share in [0, 1]; they sum
    to one, on hand-made summaries and on a stored diagnosis's decision inputs."""
    stored = Summary.from_dict(json.loads((DATA / "lab_seal_weak.summary.json").read_text()))
    made = summary(
        single("hose_compliance", BASE / 30),
        single("entrained_air", BASE / 3),
        single("sensor_delay", BASE / 2, plausible=False),
        pair("hose_compliance", "entrained_air", BASE / 32),
    )
    for s in (stored, made):
        shares = posterior(s).shares
        assert NONE in shares and UNEXPLAINED in shares
        assert all(0.0 <= p <= 1.0 for p in shares.values())
        assert sum(shares.values()) == pytest.approx(1.0, abs=1e-12)
        assert 0.0 <= decide(s).confidence <= 1.0
    # an implausible fit is never a hypothesis of its own: its evidence is unexplained's
    assert ("sensor_delay",) not in posterior(made).shares


def test_the_confidence_grows_with_the_error_a_hypothesis_cuts() -> None:
    """The same verdict with the same parameters, cutting the error more, is surer; a
    rival that comes nearer makes it less sure; equal rivals split the posterior."""
    seen = []
    for cut in (4.0, 6.0, 10.0, 30.0):
        s = summary(single("hose_compliance", BASE / cut), single("entrained_air", BASE / 3.5))
        verdict = decide(s)
        assert verdict.effects == ("hose_compliance",)
        seen.append(verdict.confidence)
    assert seen == sorted(seen) and seen[-1] > seen[0] + 0.1
    assert log_evidence(BASE / 10, 2, 0.0) > log_evidence(BASE / 5, 2, 0.0)
    assert log_evidence(BASE / 10, 2, 0.0) > log_evidence(BASE / 10, 3, 0.0)
    # under the noise's share a lower cost is no evidence: no model predicts the noise
    assert log_evidence(BASE / 10, 2, BASE / 5) == log_evidence(BASE / 20, 2, BASE / 5)
    tied = posterior(
        summary(single("hose_compliance", BASE / 30), single("thermal_drift", BASE / 30))
    )
    assert tied.of(("hose_compliance",)) == pytest.approx(tied.of(("thermal_drift",)))
    assert tied.of(("hose_compliance",)) < 0.5


def test_a_misfit_within_the_noise_is_none_by_the_posterior() -> None:
    """A baseline at the noise: no hypothesis cuts anything the noise does not hold, each
    is charged its parameters, and none takes the most share."""
    quiet = summary(single("hose_compliance", BASE / 1.1), noise=BASE)
    assert posterior(quiet).best() == NONE
    assert decide(quiet).effects == ()


def test_a_second_effect_is_said_only_when_the_pair_wins() -> None:
    """A clean single (the best pair with it cuts what it leaves 1.05 times) carries no
    "second effect"; a pair that cuts its leftover 5 times, far beyond the noise and its
    two more parameters, makes it likely (and the single's confidence falls)."""
    strong = single("eccentric_load", BASE / 50)
    clean = summary(
        strong,
        single("bore_friction", BASE / 1.1),
        pair("eccentric_load", "bore_friction", BASE / 52.5),
    )
    assert decide(clean).effects == ("eccentric_load",)
    assert clean.doubt(("eccentric_load",)) is None
    hidden = dataclasses.replace(
        clean, pairs=(pair("eccentric_load", "bore_friction", BASE / 250),)
    )
    assert decide(hidden).effects == ("eccentric_load",)  # 0.8 % of the baseline: not named
    assert hidden.pair_odds(strong, hidden.pairs[0]) > 0.0
    doubt = hidden.doubt(("eccentric_load",)) or ""
    assert "with bore_friction beside it" in doubt
    assert decide(hidden).confidence < decide(clean).confidence - 0.3
    # the same cut with the single already at the noise: nothing left for a second effect
    at_noise = dataclasses.replace(hidden, noise_cost=BASE / 60)
    assert at_noise.doubt(("eccentric_load",)) is None


def test_a_capped_verdict_prints_its_doubt_and_stays_a_probability() -> None:
    """A single whose own values say another physics is beside it: its number and the
    doubt in words, less sure than the same single undoubted."""
    plain = summary(single("sensor_delay", BASE / 40))
    s = dataclasses.replace(plain, not_alone={"sensor_delay": "two lags"})
    verdict = decide(s)
    assert verdict.capped == NOT_ALONE
    assert re.fullmatch(r"0\.\d\d, not sure it is alone", verdict.confidence_text())
    assert 0.0 < verdict.confidence < decide(plain).confidence
    assert not math.isnan(verdict.confidence)
