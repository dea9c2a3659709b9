"""A weak second effect beside a strong one: a signature the named single's law cannot make.

Air beside a wearing seal: the seal's stick-slip is the same on apply and release, air's
compliance falls with the pressure, so the bore pressure carries even harmonics the seal's
fit leaves, well beyond their scatter over the cycles, while the air's own fit gains nothing.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from brake_hil.diagnosis.candidates import candidate
from brake_hil.diagnosis.dataset import Window
from brake_hil.diagnosis.evidence import SegmentSignals, even_harmonics_z
from brake_hil.diagnosis.rig_findings import AIR_BESIDE_CUT, AIR_MORE_RATIO
from brake_hil.diagnosis.summary import Hypothesis, Summary, unmade_signature
from brake_hil.diagnosis.thresholds import SIGNIFICANT_Z
from brake_hil.diagnosis.verdict import NOT_ALONE, decide

RATE = 100.0  # Hz
PERIOD = 0.2  # s: 5 Hz
BASE = 1.0e-5


def _segments(extra: float, odd: float, seed: int) -> list[SegmentSignals]:
    """Three 18 s segments: a 5 Hz cycle predicted, measured with noise and a nonlinear part.

    ``extra`` scales an asymmetric part (``s**2``: stiffer on one half of the cycle, as air's
    compliance makes), ``odd`` a symmetric one (``s**3``: the same on apply and release).
    """
    rng = np.random.default_rng(seed)
    time = np.arange(0.0, 18.0, 1.0 / RATE)
    s = np.sin(2 * np.pi * time / PERIOD)
    parts = []
    for k, level in enumerate((1.0, 1.5, 2.0)):
        predicted = level * (1.0 + s)
        measured = predicted + extra * s**2 + odd * s**3 + 1e-4 * rng.standard_normal(s.size)
        window = Window(18.0 * k, 18.0 * (k + 1), level * 1e6, k)
        parts.append(
            SegmentSignals(window, time, predicted, {"p_b": measured}, {"p_b": predicted.copy()})
        )
    return parts


def test_even_harmonics_are_judged_against_their_own_scatter() -> None:
    share, z, power = even_harmonics_z(_segments(0.01, 0.0, 1), "p_b", RATE, 1 / PERIOD)
    assert share > 0 and z > 10 * SIGNIFICANT_Z and power > 0
    # a law the same on apply and release makes odd harmonics only; noise alone, none
    for odd in (0.05, 0.0):
        _, z, _ = even_harmonics_z(_segments(0.0, odd, 2), "p_b", RATE, 1 / PERIOD)
        assert abs(z) < SIGNIFICANT_Z


def test_the_air_signature_needs_no_fixed_one_percent() -> None:
    # the wearing rig's evidence: p_b off by 0.76 % only, its even harmonics 66 standard errors
    evidence = {
        "held_out_rms_p_b": 0.0076,
        "noise_nrmse": 1.27e-4,
        "even_harmonics_p_b": 0.0085,
        "even_harmonics_z_p_b": 66.0,
        "even_harmonics_power_p_b": 1.5e-6,  # 95 times the noise's share
    }
    assert candidate("entrained_air").consistent(evidence)
    assert not candidate("entrained_air").consistent({**evidence, "even_harmonics_z_p_b": 0.7})
    # the steady rig: sure, but a tenth of the noise's share
    assert not candidate("entrained_air").consistent(
        {**evidence, "even_harmonics_z_p_b": 4.7, "even_harmonics_power_p_b": 4e-9}
    )


NOISE = 1.6e-8  # the lab's noise share of the held-out cost
WEARING = (0.0085, 66.0, 96 * NOISE)  # the wearing rig's seal leaves: share %, z, power


def test_only_a_law_that_cannot_make_them_is_doubted() -> None:
    doubt = unmade_signature("seal_stick_slip", WEARING, NOISE)
    assert doubt is not None and doubt.startswith("a second effect is likely; not identified")
    assert "entrained_air" in doubt
    assert unmade_signature("seal_stick_slip", (6.6e-6, 0.67, 0.5 * NOISE), NOISE) is None
    assert unmade_signature("entrained_air", WEARING, NOISE) is None  # its law makes them
    assert unmade_signature("seal_stick_slip", (-0.01, -50.0, -NOISE), NOISE) is None
    # sure, but too small to be more than a parameter error's residue
    assert unmade_signature("seal_stick_slip", (2e-5, 4.0, 1.5 * NOISE), NOISE) is None


def _lab(even_left: dict[str, tuple[float, float, float]]) -> Summary:
    """The wearing rig's inputs: the seal cuts the error 35 times, no pair beats it."""

    def h(effects: tuple[str, ...], cost: float, parameters: int) -> Hypothesis:
        return Hypothesis(effects, parameters, cost, (cost,) * 3, True, True)

    seal = BASE / 35
    return Summary(
        baseline_cost=BASE,
        baseline_window_costs=(BASE,) * 3,
        baseline_rms=BASE**0.5,
        noise_cost=NOISE,
        singles=(h(("seal_stick_slip",), seal, 3), h(("entrained_air",), BASE, 1)),
        pairs=(h(("seal_stick_slip", "entrained_air"), seal / 1.01, 4),),
        even_left=even_left,
    )


def test_the_wearing_seal_is_named_but_not_surely_alone() -> None:
    plain = _lab({})
    assert decide(plain).effects == ("seal_stick_slip",)
    assert plain.doubt(("seal_stick_slip",)) is None  # today: sure it is alone
    words = unmade_signature("seal_stick_slip", WEARING, NOISE)
    doubted = _lab({"seal_stick_slip": WEARING})
    assert words is not None and decide(_lab({"seal_stick_slip": (6.6e-6, 0.67, 0.0)})) == (
        decide(plain)
    )
    verdict = decide(doubted)
    assert verdict.effects == ("seal_stick_slip",)  # the verdict stays; its doubt is said
    assert verdict.capped == NOT_ALONE and verdict.confidence < decide(plain).confidence
    assert doubted.doubt(("seal_stick_slip",)) == words
    # a stored input: the replay decides the same
    again = Summary.from_dict(json.loads(json.dumps(doubted.as_dict())))
    assert again.even_left == doubted.even_left and decide(again) == verdict
    # an older diagnosis.json without the key replays as before
    older = {k: v for k, v in doubted.as_dict().items() if k != "even_left"}
    assert decide(Summary.from_dict(older)) == decide(dataclasses.replace(doubted, even_left={}))


def test_more_air_than_the_rig_file_beside_the_named_seal_is_said() -> None:
    """The 10-run lab's wearing rig at its last run: seal stick-slip 0.9 and air at ten
    times the rig file's. The pair with air cuts what the seal leaves only 1.15 times (the
    posterior does not pay for it), but it fits twice the rig file's air: doubted, and said.
    The same cut with the rig file's own air, or that air with no cut, says nothing of air
    (the seal's fit still leaves even harmonics its law cannot make: that doubt stays)."""
    data = Path(__file__).with_name("data") / "lab_seal_air_strong.summary.json"
    stored = Summary.from_dict(json.loads(data.read_text()))
    ratio, cut = stored.air_beside["seal_stick_slip"]
    assert ratio > AIR_MORE_RATIO and cut >= AIR_BESIDE_CUT
    verdict = decide(stored)
    assert verdict.effects == ("seal_stick_slip",) and verdict.capped == NOT_ALONE
    words = stored.doubt(("seal_stick_slip",))
    assert words is not None and words.startswith(
        f"with entrained_air beside it the fit finds {ratio:.1f} times the rig file's air"
    )
    assert "bleed the brake" in words
    for kept in ((1.3, cut), (ratio, 1.002)):
        plain = dataclasses.replace(stored, air_beside={"seal_stick_slip": kept})
        assert plain.air_beside_words("seal_stick_slip") is None
        assert "the signature of one of" in str(plain.doubt(("seal_stick_slip",)))
    older = {k: v for k, v in stored.as_dict().items() if k != "air_beside"}
    assert Summary.from_dict(older).air_beside == {}  # stored before: replays as then
