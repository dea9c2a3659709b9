"""The groove asymmetry told from plain stick-slip: its slider, its interval, its words."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from brake_hil.diagnosis.candidates.seal_groove_asymmetry import GrooveSlider
from brake_hil.diagnosis.engine import FrictionElement, ModelSpec, simulate_batch
from brake_hil.diagnosis.fitting import Fit
from brake_hil.diagnosis.groove import (
    GROOVE,
    STICK_SLIP,
    groove_asymmetry,
    seal_asymmetry,
    symmetric_seals,
)
from brake_hil.diagnosis.physics_checks import asymmetry_check
from brake_hil.physics.excitation import pulsing_profile
from brake_hil.physics.parameters import derive_parameters
from brake_hil.physics.rig import Rig

NAMES = ("stiffness_asymmetry", "relaxation_time", "friction_share", "seal_spring", "slip_force")


def _groove(a: float, sigma: float, cost: float = 1e-6) -> Fit:
    theta = np.array([a, 1.0, 0.6, 2.0e7, 200.0])
    uncertainty = np.array([sigma, 1.0, 0.1, 1e6, 10.0])
    return Fit((GROOVE,), theta, NAMES, ("-",) * 5, cost, cost, {}, uncertainty)


def _symmetric(effects: tuple[str, ...], cost: float) -> Fit:
    return Fit(effects, np.zeros(3), ("a", "b", "c"), ("-",) * 3, cost, cost, {})


BASELINE = _symmetric((), 1e-4)
STICK = _symmetric((STICK_SLIP,), 1.0e-6)


def test_an_asymmetry_whose_interval_excludes_symmetry_is_resolved() -> None:
    groove = seal_asymmetry(_groove(0.3, 0.05), [BASELINE, STICK])
    assert groove is not None and groove.asymmetric and groove.resolved
    assert groove.ratio == pytest.approx(1.3 / 0.7)
    assert groove.interval[0] > 1.0  # (1 + 0.2) / (1 - 0.2) = 1.5
    document = groove.as_dict((GROOVE,))
    assert document["resolved"] is True and document["named"] is True
    assert document["answer"] == "asymmetric"
    assert "groove asymmetry resolved" in groove.verdict_words((GROOVE,))
    assert asymmetry_check(_groove(0.3, 0.05), [BASELINE, STICK]).passed  # type: ignore[union-attr]


def test_a_wide_interval_is_not_resolved_and_says_so() -> None:
    """A symmetric stick-slip seal whose groove fit leaves a wide interval of ``a``."""
    groove = seal_asymmetry(_groove(0.01, 0.4), [BASELINE, STICK])
    assert groove is not None and not groove.resolved
    words = groove.verdict_words((STICK_SLIP,))
    assert words.startswith("stick-slip; groove asymmetry not resolved")
    document = groove.as_dict((STICK_SLIP,))
    assert document["resolved"] is False and document["named"] is False
    low, high = document["interval"]  # type: ignore[misc]
    assert low < 1.0 < high
    outcome = asymmetry_check(_groove(0.01, 0.4), [BASELINE, STICK])
    assert outcome is not None and not outcome.passed and "not resolved" in outcome.finding


def test_a_tight_interval_about_symmetry_is_a_resolved_symmetric_seal() -> None:
    groove = seal_asymmetry(_groove(0.005, 0.01), [BASELINE, STICK])
    assert groove is not None and groove.symmetric and groove.resolved
    assert not groove.asymmetric
    words = groove.verdict_words((STICK_SLIP,))
    assert "symmetric seal" in words and "not resolved" not in words
    assert groove.as_dict((STICK_SLIP,))["answer"] == "symmetric"


def test_a_groove_far_better_than_every_symmetric_seal_is_asymmetric() -> None:
    """A frictionless groove whose unidentified frictional share widens the interval of a:
    it still leaves a sixth of what stick-slip and the baseline leave."""
    wide = _groove(0.24, 0.22, cost=1e-6)
    worse_stick = _symmetric((STICK_SLIP,), 6e-6)
    assert seal_asymmetry(wide, [BASELINE, worse_stick]).asymmetric  # type: ignore[union-attr]
    # against a stick-slip that fits as well, the same interval is not resolved
    assert not seal_asymmetry(wide, [BASELINE, STICK]).resolved  # type: ignore[union-attr]


def test_a_groove_beside_another_effect_is_held_against_stick_slip_beside_it() -> None:
    """A groove with an eccentric load is judged against stick-slip with the same load, not
    against stick-slip alone: alone, the seal leaves the load's share of the error too, and a
    symmetric five-washer seal came out a resolved groove."""
    pair = replace(_groove(-0.03, 0.2, cost=1.0e-6), effects=(GROOVE, "eccentric_load"))
    stick_alone = _symmetric((STICK_SLIP,), 20e-6)
    stick_beside = _symmetric(("eccentric_load", STICK_SLIP), 1.05e-6)
    seals = symmetric_seals(BASELINE, [stick_alone], [stick_alone, stick_beside], pair.effects)
    assert seals == [BASELINE, stick_alone, stick_beside]
    assert seal_asymmetry(pair, [BASELINE, stick_alone]).asymmetric  # type: ignore[union-attr]
    assert not seal_asymmetry(pair, seals).asymmetric  # type: ignore[union-attr]
    assert symmetric_seals(BASELINE, [stick_alone], [stick_beside], (STICK_SLIP,)) == [
        BASELINE,
        stick_alone,
    ]


def test_only_a_seal_verdict_carries_the_groove() -> None:
    singles = [STICK, _groove(0.01, 0.4)]
    assert groove_asymmetry(("orifice_flow",), BASELINE, singles) is None
    assert groove_asymmetry((), BASELINE, singles) is None
    assert groove_asymmetry((STICK_SLIP,), BASELINE, singles) is not None
    assert groove_asymmetry((STICK_SLIP,), BASELINE, [STICK]) is None  # no groove fitted
    assert asymmetry_check(STICK) is None


@pytest.fixture(scope="module")
def pressure() -> np.ndarray:
    return pulsing_profile((1.38e6,), pulsing_s=2.0)[1]


def _slider_outputs(default_rig: Rig, pressure: np.ndarray, *terms: object) -> np.ndarray:
    params = derive_parameters(default_rig, 1.08e6)
    return simulate_batch(ModelSpec((params,), tuple(terms)), pressure, 1e-3)[0]  # type: ignore[arg-type]


def test_a_symmetric_groove_slider_is_the_jenkins_element(default_rig: Rig, pressure) -> None:  # type: ignore[no-untyped-def]
    """At a = 0 the groove's slider sticks and slips exactly as stick-slip's."""
    spring, threshold = np.array([2.0e7]), np.array([150.0])
    groove = _slider_outputs(default_rig, pressure, GrooveSlider(spring, threshold, np.zeros(1)))
    jenkins = _slider_outputs(
        default_rig, pressure, FrictionElement(spring, threshold, threshold.copy())
    )
    scale = np.ptp(jenkins, axis=1)[:, None]
    assert np.max(np.abs(groove - jenkins) / scale) < 1e-9
    # and it does slip here: a spring that never slips moves the outputs
    stuck = _slider_outputs(
        default_rig, pressure, FrictionElement(spring, np.array([1e9]), np.array([1e9]))
    )
    assert np.max(np.abs(stuck - jenkins) / scale) > 1e-3


def test_an_asymmetric_groove_slider_has_a_softer_apply_edge(default_rig: Rig, pressure) -> None:  # type: ignore[no-untyped-def]
    """Stuck softer on apply edges, stiffer on release edges: x_c (the caliper's reading of
    the seal's pull) moves more per unit of pressure while the pressure rises."""
    spring, threshold = np.array([2.0e7]), np.array([150.0])
    outputs = {
        a: _slider_outputs(default_rig, pressure, GrooveSlider(spring, threshold, np.array([a])))
        for a in (-0.5, 0.0, 0.5)
    }
    steady = slice(pressure.size // 2, None)
    rising = np.diff(pressure[steady]) > 0
    slopes = {}
    for a, out in outputs.items():
        dx = np.diff(out[2, steady])
        dp = np.diff(pressure[steady])
        apply = np.sum(dx[rising] * dp[rising]) / np.sum(dp[rising] ** 2)
        release = np.sum(dx[~rising] * dp[~rising]) / np.sum(dp[~rising] ** 2)
        slopes[a] = apply / release
    # symmetric: the edges differ only by the line's lag (0.96); a = 0.5: 1.04
    assert slopes[0.5] > slopes[0.0] + 0.04
    assert slopes[-0.5] < slopes[0.0] - 0.04  # stiffer on apply: the other way


def test_an_interval_the_recording_does_not_bound_is_said_so() -> None:
    """A groove fit whose ``a`` is free across its whole range gives no interval in numbers."""
    loose = seal_asymmetry(_groove(0.3, 5.0), [BASELINE, STICK])
    assert loose is not None and not loose.resolved
    assert "interval not bounded" in loose.verdict_words((STICK_SLIP,))
    bounded = seal_asymmetry(_groove(0.01, 0.4), [BASELINE, STICK])
    assert bounded is not None and "interval 0." in bounded.verdict_words((STICK_SLIP,))
