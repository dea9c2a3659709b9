"""A rig's trend: silent on steady rigs, a plain line for each thing that wore."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
import math

import numpy as np
import pytest

from brake_hil.diagnosis.calibration import BORE_COMPLIANCE, PROPAGATED, UNCERTAIN
from brake_hil.diagnosis.rig_findings import air_text
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.results.trend import (
    ADVICE,
    OUTSIDE_SIGMA,
    SIGNIFICANCE,
    TREND_RUNS,
    Movement,
    Series,
    identified,
    rig_trend,
    trends,
)
from brake_hil.results.trend_statistics import _fit, _trend_p_value
from test.results.fleets import (
    PRIOR_SIGMA,
    Run,
    carry_air,
    real_document,
    rows,
    steady_fleet,
    wearing_fleet,
)


def test_a_steady_rig_gets_no_line_in_at_least_99_percent_of_fleets() -> None:
    # 200 steady fleets of 30 runs: values at offsets within their band with heavy-tailed,
    # day-to-day correlated scatter up to a third of the tolerance, effects steady (named or
    # not): at most 1 % of them may get a line (docs/benchmarks.md has the measured rate).
    noisy = [seed for seed in range(200) if rig_trend(rows(steady_fleet(_rng(seed)))).findings]
    assert len(noisy) <= 2, noisy


def _rng(seed: int) -> np.random.Generator:
    return np.random.default_rng(seed)


def _alarms(fleet: Callable[[int], list[Run]], said: Callable[[Series], bool]) -> list[int]:
    """The seeds of 200 fleets whose trend has a series ``said`` holds for."""
    return [seed for seed in range(200) if any(map(said, rig_trend(rows(fleet(seed))).series))]


@pytest.mark.parametrize("seed", range(5))
def test_a_wearing_rig_gets_a_line_for_each_thing_that_wore(seed: int) -> None:
    trend = rig_trend(rows(wearing_fleet(_rng(10_000 + seed), 40)))
    found = {s.name: s for s in trend.series if s.finding is not None}
    assert set(found) == {"caliper_stiffness", "air_fraction", "seal_stick_slip"}
    caliper = found["caliper_stiffness"]
    assert caliper.movement is Movement.DRIFT
    assert caliper.finding is not None
    assert caliper.finding.startswith("caliper stiffness fell 1")
    assert caliper.finding.endswith("over 40 runs (tolerance ±25 %): check the caliper mounting")
    assert caliper.interval[1] < 0
    air = found["air_fraction"].finding
    assert air is not None and air.startswith("fluid air fraction rose")
    assert "now above it" in air and air.endswith("air in the fluid: bleed the circuit")
    seal = found["seal_stick_slip"]
    assert seal.movement is Movement.GREW
    assert seal.finding is not None and seal.finding.startswith(
        "seal stick-slip grew over 40 runs"
    )
    assert seal.finding.endswith(": seal wear")
    assert trend.summary()[:3] == list(trend.findings)


def test_the_fitted_line_follows_the_drift() -> None:
    trend = rig_trend(rows(wearing_fleet(_rng(7), 40)))
    caliper = next(s for s in trend.series if s.name == "caliper_stiffness")
    line = caliper.line()
    assert line[0] == pytest.approx(1.0, abs=0.03)
    assert line[-1] == pytest.approx(0.88, abs=0.03)
    assert caliper.band == pytest.approx((math.exp(-0.25), math.exp(0.25)))


def test_a_value_off_the_rig_file_in_every_run_says_update_the_rig_file() -> None:
    fleet = steady_fleet(_rng(3), 20)
    for number, run in enumerate(fleet):
        run.logs["valve_resistance"] = math.log(1.6) + 0.01 * (-1) ** number
        run.identified["valve_resistance"] = True
    trend = rig_trend(rows(fleet))
    [line] = [s.finding for s in trend.series if s.finding]
    assert line == (
        "needle-valve resistance sits 60 % above the rig file in every run "
        "(tolerance ±40 %): update the rig file"
    )


def test_an_offset_standing_in_for_a_named_effect_is_no_rig_file_error() -> None:
    # The calibrated LTI model puts a stick-slip seal's misfit into its viscous k_eh: a seal
    # stiffness far below the rig file in every run where stick-slip is named is that
    # stand-in, not a wrong rig file (the steady rig of `brake-hil fleet`, 0.59 in 30 runs).
    fleet = steady_fleet(_rng(5), 20)
    for number, run in enumerate(fleet):
        run.logs["effective_hydraulic_stiffness"] = math.log(0.55) + 0.01 * (-1) ** number
        run.identified["effective_hydraulic_stiffness"] = True
        run.named = ["seal_stick_slip"] if number % 4 else []
    trend = rig_trend(rows(fleet))
    [line] = [s.finding for s in trend.series if s.finding]
    assert line.endswith(
        "the calibrated LTI model stands in with it for the seal stick-slip named in 15 of "
        "20 runs, not a rig-file error"
    )


def test_with_too_few_runs_for_a_trend_it_says_so_and_no_trend() -> None:
    trend = rig_trend(rows(wearing_fleet(_rng(1), 4)))
    assert trend.findings == ()
    assert all(s.movement is Movement.TOO_FEW for s in trend.series)
    assert trend.summary()[0] == "4 runs: too few to test a trend; 8 needed"


def test_trend_runs_is_the_fewest_a_perfectly_monotone_series_passes_the_test() -> None:
    # The rule's own arithmetic: 7 monotone runs give p about 0.003, 8 give under 0.001.
    assert TREND_RUNS == 8
    for n, passes in ((TREND_RUNS - 1, False), (TREND_RUNS, True)):
        x = np.arange(n, dtype=float)
        assert (_trend_p_value(x, 0 * x) < SIGNIFICANCE) is passes
        assert _fit(x, -x).significant is passes


def _k_eh_lab(runs: int) -> tuple[list[Run], list[Run]]:
    """``brake-hil fleet``'s two rigs as the diagnoses saw them: rig-1's seal k_eh falls from
    0.84 to 0.12 of the rig file's (tolerance ±50 %); rig-2's sits at 0.59 in every run (the
    LTI model's stand-in for the stick-slip it names), the rest steady."""
    wearing, steady = steady_fleet(_rng(runs), runs), steady_fleet(_rng(runs + 1), runs)
    for number, (worn, kept) in enumerate(zip(wearing, steady)):
        fall = 0.843 - (0.843 - 0.117) * number / (runs - 1)
        worn.logs["effective_hydraulic_stiffness"] = math.log(fall)
        kept.logs["effective_hydraulic_stiffness"] = math.log(0.59) + 0.03 * (-1) ** number
        for run in (worn, kept):
            run.identified["effective_hydraulic_stiffness"] = True
            run.named = ["seal_stick_slip"]
    return wearing, steady


@pytest.mark.parametrize("runs", [5, 10, 30])
def test_the_wearing_rig_of_a_lab_is_flagged_at_once_and_the_steady_one_not(runs: int) -> None:
    wearing, steady = _k_eh_lab(runs)
    worn = rig_trend(rows(wearing, "rig-1"))
    lines = worn.summary()
    seal = next(s for s in worn.series if s.name == "effective_hydraulic_stiffness")
    assert seal.finding is not None and seal.finding in lines
    if runs < TREND_RUNS:  # no trend test: the run outside its band, said at once
        assert seal.movement is Movement.OUTSIDE
        assert seal.finding.startswith(
            f"run {runs}: seal stiffness k_eh at 0.12 of the rig file's value, outside its "
            "tolerance ±50 % (4.3 times it"
        )
        assert f"{runs} runs: too few to test a trend; 8 needed" in lines
    elif runs < 30:  # a curved fall on 10 runs: a run outside its band, or a drift
        assert seal.movement in (Movement.OUTSIDE, Movement.DRIFT)
    else:  # 30 runs: the fall is a drift, now below the band
        assert seal.movement is Movement.DRIFT and "now below it" in seal.finding
    assert not any("left its band" in line for line in lines)
    kept = rig_trend(rows(steady, "rig-2"))
    assert not any("outside its tolerance" in line for line in kept.summary())
    assert all(s.movement is not Movement.OUTSIDE for s in kept.series)


def test_a_run_far_outside_its_band_is_flagged_whatever_the_runs_around_it() -> None:
    fleet = steady_fleet(_rng(21), 20)
    for run in fleet:
        run.logs["caliper_stiffness"] = 0.0
        run.identified["caliper_stiffness"] = True
    fleet[6].logs["caliper_stiffness"] = -OUTSIDE_SIGMA * 0.25 * 1.1  # one bad day
    trend = rig_trend(rows(fleet))
    caliper = next(s for s in trend.series if s.name == "caliper_stiffness")
    assert caliper.movement is Movement.OUTSIDE and caliper.outside == (6,)
    assert caliper.finding is not None and caliper.finding.startswith(
        "run 7: caliper stiffness at 0.44 of the rig file's value, outside its tolerance ±25 %"
    )


def test_no_line_never_says_nothing_left_its_band_when_a_value_did() -> None:
    fleet = steady_fleet(_rng(22), 12)
    for run in fleet:
        run.logs = dict.fromkeys(run.logs, 0.0)
        run.identified = dict.fromkeys(run.identified, True)
        run.strengths = dict.fromkeys(run.strengths, 0.0)
    fleet[3].logs["valve_resistance"] = 1.5 * 0.4  # outside its band once, within 3 of it
    trend = rig_trend([replace(r, effects=()) for r in rows(fleet)])
    assert trend.findings == ()
    assert trend.summary() == [
        "no drift, offset or growth beyond doubt over 12 runs; outside the band in some "
        "runs, without a trend: needle-valve resistance (1 of 12)"
    ]


def test_the_outside_rule_rarely_fires_on_steady_fleets() -> None:
    # docs/benchmarks.md has the measured rate (200 steady fleets of 30 runs).
    alarms = _alarms(
        lambda seed: steady_fleet(_rng(seed)), lambda s: s.movement is Movement.OUTSIDE
    )
    assert len(alarms) <= 6, alarms


def test_a_value_the_runs_do_not_identify_is_not_trended() -> None:
    fleet = wearing_fleet(_rng(2), 30)
    for run in fleet:
        run.identified["caliper_stiffness"] = False
    trend = rig_trend(rows(fleet))
    caliper = next(s for s in trend.series if s.name == "caliper_stiffness")
    assert caliper.movement is Movement.TOO_FEW and caliper.finding is None
    assert any(
        line.startswith("identified in too few runs to test a trend: caliper")
        for line in trend.summary()
    )


def test_only_the_latest_rig_file_is_trended() -> None:
    old = rows(steady_fleet(_rng(4), 10), rig_hash="old" * 20)
    new = rows(steady_fleet(_rng(5), 12))
    trend = rig_trend([*old, *new])
    assert len(trend.rows) == 12 and trend.earlier == 10
    assert trend.summary()[-1].startswith("10 earlier diagnoses used another version")


def test_trends_are_one_per_rig_sorted_by_name() -> None:
    mixed = rows(steady_fleet(_rng(6), 6), rig="rig B") + rows(steady_fleet(_rng(8), 6))
    assert [t.rig for t in trends(mixed)] == ["rig B", "test rig"]


def test_every_calibrated_value_and_effect_has_its_advice() -> None:
    values = {u.name for u in (*UNCERTAIN, BORE_COMPLIANCE, *PROPAGATED)}
    assert values | set(CATALOGUE) == set(ADVICE)


def test_identified_is_the_calibrations_own_rule() -> None:
    calibration = real_document()["calibration"]
    judged = {
        name
        for name, prior in calibration["prior_sigma"].items()
        if not identified(prior, calibration["posterior_sigma"][name])
    }
    assert judged == set(calibration["not_identified"])


def test_a_constant_series_is_steady() -> None:
    fleet = steady_fleet(_rng(9), 12)
    for run in fleet:
        run.logs = dict.fromkeys(run.logs, 0.0)
        run.identified = dict.fromkeys(run.identified, True)
        run.strengths = dict.fromkeys(run.strengths, 0.0)
    trend = rig_trend([replace(r, effects=()) for r in rows(fleet)])
    assert trend.findings == ()
    assert trend.summary() == ["no value or effect left its band over 12 runs"]


def test_an_air_finding_says_which_air_as_the_verdict_said_it() -> None:
    base = rows(wearing_fleet(_rng(10_007), 40))
    for state, ratio, ending in (
        (
            "more_than_rig_file",
            2.6,
            "more air than the rig file says (2.6 times): bleed the brake",
        ),
        ("as_rig_file", 1.1, "as the rig file's air would; the improved model carries it"),
    ):
        said = f"entrained_air: ... The air: {air_text(state, ratio)}."
        told = [*base[:-1], replace(base[-1], explanation=said)]
        air = next(s for s in rig_trend(told).series if s.name == "air_fraction").finding
        assert air is not None and air.startswith("fluid air fraction rose")
        assert air.endswith(ending) and "bleed the circuit" not in air


def test_a_drift_of_the_lti_model_alone_is_said_as_its_stand_in() -> None:
    """The LTI-only calibration lowers the caliper stiffness run after run beside a stick-slip
    seal (a stand-in the catalogue does not list), while the improved model holds it at the
    rig file's: the line says so, and names no rig fault. Without improved values the same
    series is a drift of the rig."""
    fleet = steady_fleet(_rng(7), 30)
    for number, run in enumerate(fleet):
        run.logs["caliper_stiffness"] = math.log(1.0 - 0.34 * number / 29)
        run.identified["caliper_stiffness"] = True
        run.named = ["seal_stick_slip"]
    plain = rows(fleet)
    modelled = [
        replace(
            row,
            calibration=tuple(
                replace(v, improved_multiplier=1.01) if v.name == "caliper_stiffness" else v
                for v in row.calibration
            ),
        )
        for row in plain
    ]
    [drift] = [s for s in rig_trend(plain).series if s.name == "caliper_stiffness"]
    assert drift.finding and drift.finding.endswith("check the caliper mounting")
    assert not drift.stand_in
    [stand_in] = [s for s in rig_trend(modelled).series if s.name == "caliper_stiffness"]
    assert stand_in.stand_in and stand_in.finding
    assert stand_in.finding.endswith(
        "within its tolerance in 30 of 30 runs once the seal stick-slip is modelled: the LTI "
        "model's stand-in for it, not the rig"
    )


def test_air_collecting_beside_a_named_seal_is_found_with_the_seal_modelled() -> None:
    """The LTI model identifies the air in no run beside the seal; the improved model, with
    the seal modelled, holds it rising 2.2 times over 30 runs (the 30-run lab's wearing rig):
    one line, in the improved model's words. On 5 runs, no trend test and no line."""
    fleet = carry_air(_rng(31), steady_fleet(_rng(30), 30), rise=2.2)
    trend = rig_trend(rows(fleet))
    [air] = [s for s in trend.series if s.modelled == "seal_stick_slip"]
    assert air.name == "air_fraction" and air.movement is Movement.DRIFT
    assert air.finding is not None and air.finding in trend.summary()
    assert air.finding.startswith("with the seal stick-slip modelled, fluid air fraction rose")
    band = f"±{100 * PRIOR_SIGMA['air_fraction']:.0f} %"
    assert air.finding.endswith(
        f"over 30 runs (tolerance {band}): air in the fluid: bleed the circuit"
    )
    lti = next(s for s in trend.series if s.name == "air_fraction" and s.modelled is None)
    assert lti.finding is None and lti.movement is Movement.TOO_FEW
    short = rig_trend(rows(carry_air(_rng(31), steady_fleet(_rng(30), 5), rise=2.2)))
    assert not any(s.modelled for s in short.series)


def test_the_improved_models_steady_air_rarely_gets_a_line() -> None:
    # docs/benchmarks.md has the measured rate (bench_trend_alarms.py, 2000 fleets).
    alarms = _alarms(
        lambda seed: carry_air(_rng(seed + 1), steady_fleet(_rng(seed))),
        lambda s: bool(s.modelled and s.finding),
    )
    assert len(alarms) <= 2, alarms


def test_a_doubted_confidence_is_said_in_words_in_the_runs_table() -> None:
    from brake_hil.report.trend_report import _runs_table

    base = rows(steady_fleet(_rng(12), 3))
    older = replace(
        base[0],
        confidence=0.711,
        explanation="seal_stick_slip: ... How sure: likely, not sure it is alone; the "
        "confidence is that rule's cap, not a measured one.",
    )
    doubted = replace(
        base[1],
        confidence=0.41,
        explanation="seal_stick_slip: ... How sure: 0.41, not sure it is alone: how often "
        "verdicts like this one (one effect, 3.2 times the best rival's cut) were right ...",
    )
    measured = replace(
        base[2], confidence=0.87, explanation="... How sure: 0.87: how often verdicts ..."
    )
    assert older.confidence_text == "0.71, not sure it is alone"
    assert doubted.confidence_text == "0.41, not sure it is alone"
    assert measured.confidence_text == "0.87"
    table = _runs_table(rig_trend([older, doubted, measured]))
    assert "<td>0.41, not sure it is alone</td>" in table and "<td>0.87</td>" in table
