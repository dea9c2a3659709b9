"""The calibration's prior carries every toleranced rig value; rig values and air in words."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from brake_hil.diagnosis.calibration import (
    Calibration,
    prior,
    uncertain_values,
)
from brake_hil.diagnosis.rig_findings import (
    AIR_MORE_RATIO,
    AS_RIG_FILE,
    air_finding,
    air_in_words,
    air_text,
    for_verdict,
    outside,
    verdict_notes,
)
from brake_hil.physics.rig import Rig, load_rig
from brake_hil.report.next_steps import next_steps
from test.conftest import PROJECT

RIG_FILE = PROJECT / "config" / "rig_default.yaml"


def _sigmas(rig: Rig) -> tuple[dict[str, float], dict[str, tuple[str, ...]]]:
    covariance, setters = prior(rig, uncertain_values(rig))
    names = [u.name for u in uncertain_values(rig)]
    return dict(zip(names, np.sqrt(np.diag(covariance)).tolist())), setters


def test_the_bore_length_is_carried_into_the_bore_compliance_it_sets() -> None:
    rig = load_rig(RIG_FILE)
    sigmas, setters = _sigmas(rig)
    # C_b = V_b (fluid + walls + air / p): the bore's volume scales the hose wall's share and
    # the air's alike, so its tolerance widens both priors
    assert "bore.length" in setters["hose_stiffness"]
    assert sigmas["hose_stiffness"] > 2.0 * rig.tolerance("hose.youngs_modulus")
    assert sigmas["caliper_stiffness"] == pytest.approx(0.25, rel=1e-3)  # one key sets it
    assert setters["caliper_stiffness"] == ("caliper.stiffness",)


def test_an_exact_value_adds_nothing_and_an_override_keeps_its_own_tolerance() -> None:
    rig = load_rig(RIG_FILE)
    geometry = ("bore.length", "bore.area_ratio", "washer_thickness", "pistons.diameter")
    exact = replace(rig, tolerances={**rig.tolerances, **dict.fromkeys(geometry, 0.0)})
    assert _sigmas(exact)[0]["hose_stiffness"] < 0.8 * _sigmas(rig)[0]["hose_stiffness"]
    overridden = replace(rig, model_overrides={**rig.model_overrides, "k_c": 3.0e7})
    sigmas, setters = _sigmas(overridden)
    assert sigmas["caliper_stiffness"] == pytest.approx(rig.tolerance("caliper.stiffness"))
    assert setters["caliper_stiffness"] == ("caliper.stiffness",)


@pytest.mark.parametrize(
    ("multiplier", "sigma", "posterior", "expected"),
    [
        (1.10, 0.1, 0.01, False),  # at the tolerance's edge: within
        (0.90, 0.1, 0.01, False),
        (0.60, 0.4, 0.01, False),  # the valve at -40 %: within
        (2.28, 0.538, 0.01, False),  # k_eh as a contract-spanning null fitted it
        (1.25, 0.1, 0.01, True),  # 2.2 sigmas
        (0.50, 0.25, 0.01, True),  # k_c at -2 tolerances
        (0.60, 0.2, 0.01, True),  # a bore-volume-like value at -2 tolerances
        (1.25, 0.1, 0.2, False),  # not pinned down by the recording
        (0.05, 1.0, 0.01, True),  # the air at a twentieth: 3 sigmas below
    ],
)
def test_outside_its_tolerance(
    multiplier: float, sigma: float, posterior: float, expected: bool
) -> None:
    assert outside(multiplier, sigma, posterior) is expected


def _calibration(rig: Rig, multipliers: dict[str, float]) -> Calibration:
    names = [u.name for u in uncertain_values(rig)]
    covariance, setters = prior(rig, uncertain_values(rig))
    sigma = np.sqrt(np.diag(covariance))
    return Calibration(
        rig=rig,
        multipliers={n: multipliers.get(n, 1.0) for n in names},
        sigmas=dict(zip(names, sigma.tolist())),
        uncertainty=dict.fromkeys(names, 0.01),
        cost=0.0,
        setters=setters,
    )


def test_a_value_far_outside_is_named_with_its_keys_and_no_effect_needed() -> None:
    rig = load_rig(RIG_FILE)
    calibration = _calibration(rig, {"caliper_stiffness": 0.5})
    parameters = {f"calibration.{k}": v for k, v in calibration.multipliers.items()}
    values, air, words = for_verdict(calibration, parameters, (), 1.0e6)
    assert [v["quantity"] for v in values] == ["caliper_stiffness"]
    assert values[0]["keys"] == ["caliper.stiffness"]
    assert values[0]["ratio"] == pytest.approx(0.5)
    assert values[0]["fitted"] == pytest.approx(0.5 * rig.caliper_stiffness)
    assert values[0]["sigmas"] == pytest.approx(np.log(0.5) / 0.25, abs=0.01)
    assert "check caliper stiffness" in str(values[0]["text"])
    assert words.startswith("A rig value far outside its tolerance: caliper stiffness at 0.50")
    assert air is None
    assert verdict_notes({"rig_values": values})[0].startswith("rig value: caliper stiffness")
    within = _calibration(rig, {"caliper_stiffness": 0.8, "hose_stiffness": 1.15})
    assert for_verdict(within, {}, (), 1.0e6) == ([], None, "")


def test_the_air_as_the_rig_file_says_or_more() -> None:
    rig = load_rig(RIG_FILE)
    calibration = _calibration(rig, {})
    same = air_finding(calibration, {"air_fraction": 1.1}, 0.0, 1.0e6)
    assert same is not None and same["state"] == "as_rig_file" and same["text"] == AS_RIG_FILE
    assert "bleed" not in str(same["text"])
    # 2 x the rig file's air: the candidate's share at gauge zero, seen at 1 MPa
    share = rig.fluid.air_fraction * (1.0e6 + 1.013e5) ** 2 / (1.013e5 * 1.0e6)
    more = air_finding(calibration, {"air_fraction": 1.0}, share, 1.0e6)
    assert more is not None and more["ratio"] == pytest.approx(2.0, rel=1e-3)
    assert more["state"] == "more_than_rig_file"
    assert more["text"] == "more air than the rig file says (2.0 times): bleed the brake"
    assert air_finding(calibration, {"air_fraction": 1.2}, None, 1.0e6) is None
    # no candidate: past its tolerance where a pair with the air shows it
    calibrated = air_finding(calibration, {"air_fraction": 2.5}, None, 1.0e6, shown=True)
    assert calibrated is not None and calibrated["state"] == "more_than_rig_file"
    assert air_finding(calibration, {"air_fraction": 1.7}, None, 1.0e6) is None  # in its band
    assert air_finding(calibration, {"air_fraction": 0.05}, None, 1.0e6) is None  # less air
    assert 1.3 < AIR_MORE_RATIO < 2.0


def test_the_air_named_alone_is_read_as_the_calibrated_lti_model_fitted_it() -> None:
    """Named alone, the air is the calibrated fraction (the rig file's own law and terms),
    not the candidate's share said at the mean pressure; beside another effect, the
    verdict's own model (the calibrated fraction would carry that effect too)."""
    rig = load_rig(RIG_FILE)
    calibration = _calibration(rig, {"air_fraction": 2.1})
    share = 0.5 * rig.fluid.air_fraction * (1.0e6 + 1.013e5) ** 2 / (1.013e5 * 1.0e6)
    fitted = {"calibration.air_fraction": 1.0, "air_share": share}  # reads 1.5 times
    _, alone, words = for_verdict(calibration, fitted, ("entrained_air",), 1.0e6)
    assert alone is not None and alone["ratio"] == pytest.approx(2.1)
    assert alone["state"] == "more_than_rig_file" and "(2.1 times): bleed" in words
    _, beside, _ = for_verdict(calibration, fitted, ("entrained_air", "hose_compliance"), 1.0e6)
    assert beside is not None and beside["ratio"] == pytest.approx(1.5, rel=1e-3)
    assert beside["state"] == "as_rig_file"
    same = _calibration(rig, {"air_fraction": 1.3})
    _, rig_files, words = for_verdict(same, fitted, ("entrained_air",), 1.0e6)
    assert rig_files is not None and rig_files["state"] == "as_rig_file"
    assert "bleed" not in words


def test_the_air_is_said_the_same_way_where_it_is_read_back() -> None:
    for state, ratio in (("more_than_rig_file", 2.6), ("as_rig_file", 1.1)):
        text = air_text(state, ratio)
        assert air_in_words(f"entrained_air: ... The air: {text}.") == text
    assert air_in_words("seal_stick_slip: nothing about air") is None


def test_next_steps_say_to_correct_the_rig_file_when_only_a_value_is_off(tmp_path: Path) -> None:
    page = next_steps("rec", tmp_path, None, False, ["x"], ["caliper stiffness at 0.50"])
    assert "Correct the rig file or the rig" in page and "caliper stiffness at 0.50" in page
    assert "The rig file's model stands" not in page
    assert "The rig file's model stands" in next_steps("rec", tmp_path, None, False, [])


def test_the_force_areas_are_calibrated_under_the_geometry_tolerances() -> None:
    """The piston diameter (10 %) sets the pistons' area ``A_ep`` (its square: one sigma of
    20 %) and, with the bore's area ratio (10 %), the caliper's force area ``A_eb``: the
    piston area is calibrated under the diameter's tolerance, the force area's own prior is
    the ratio's."""
    rig = load_rig(RIG_FILE)
    sigmas, setters = _sigmas(rig)
    assert setters["piston_area"] == ("pistons.diameter",)
    assert sigmas["piston_area"] == pytest.approx(0.2, rel=0.02)
    assert setters["bore_area"] == ("bore.area_ratio",)
    assert sigmas["bore_area"] == pytest.approx(0.1, rel=0.02)
    exact = replace(rig, tolerances={**rig.tolerances, "bore.area_ratio": 0.0})
    assert "bore_area" not in {u.name for u in uncertain_values(exact)}
    exact = replace(rig, tolerances={**rig.tolerances, "pistons.diameter": 0.0})
    assert "piston_area" not in {u.name for u in uncertain_values(exact)}


def test_a_force_area_within_its_tolerance_leaves_the_baseline_at_the_noise(
    default_rig: Rig,
) -> None:
    """A rig whose bore area ratio is 12 % under the rig file's (within its 10 % one-sigma
    tolerance) is no evidence of physics: the calibrated baseline finds the share and leaves
    the noise (twice its cost). Without the force area among the calibrated values, the
    baseline left 130 times the noise's cost, and an eccentric load took it."""
    from brake_hil.diagnosis.calibration import calibrate
    from brake_hil.diagnosis.dataset import prepare
    from brake_hil.diagnosis.fitting import Model, fit
    from brake_hil.virtual_rig.excitation import seed_pulsing
    from brake_hil.virtual_rig.simulator import simulate_rig

    truth = replace(default_rig, bore_area_ratio=0.88 * default_rig.bore_area_ratio)
    run = simulate_rig(truth, [], seed_pulsing((1.38e6, 2.76e6), pulsing_s=3.0), seed=5)
    dataset = prepare(run.as_recording(), default_rig)
    calibration = calibrate(dataset, default_rig)
    assert calibration.multipliers["bore_area"] == pytest.approx(0.88, abs=0.04)
    baseline = fit(Model(calibration, [], dataset))
    assert baseline.held_out_cost < 4.0 * dataset.noise_cost()


def test_a_piston_diameter_within_its_tolerance_leaves_the_baseline_at_the_noise(
    default_rig: Rig,
) -> None:
    """Pistons 9 % wider than the rig file says (within its 10 % tolerance) push 19 % more
    force onto the pads per pascal: no evidence of physics. The calibrated baseline finds the
    area and leaves the noise. With the piston area held at the rig file's, the baseline
    missed by thousands of times the noise's cost on such rigs, and a seal's stick-slip or
    `unexplained` took it."""
    from brake_hil.diagnosis.calibration import calibrate
    from brake_hil.diagnosis.dataset import prepare
    from brake_hil.diagnosis.fitting import Model, fit
    from brake_hil.virtual_rig.excitation import seed_pulsing
    from brake_hil.virtual_rig.simulator import simulate_rig

    truth = replace(default_rig, piston_diameter=1.09 * default_rig.piston_diameter)
    run = simulate_rig(truth, [], seed_pulsing((1.38e6, 2.76e6), pulsing_s=3.0), seed=5)
    dataset = prepare(run.as_recording(), default_rig)
    calibration = calibrate(dataset, default_rig)
    assert calibration.multipliers["piston_area"] == pytest.approx(1.09**2, abs=0.05)
    baseline = fit(Model(calibration, [], dataset))
    assert baseline.held_out_cost < 4.0 * dataset.noise_cost()


def test_the_prior_steepens_beyond_two_tolerances() -> None:
    """Within ``PRIOR_EDGE`` sigmas the prior is the tolerances' Gaussian; past it each sigma
    costs ``BEYOND_TOLERANCE_SLOPE`` times as much, with no jump at the edge."""
    from brake_hil.diagnosis.calibration import (
        BEYOND_TOLERANCE_SLOPE,
        PRIOR_EDGE,
        prior_residual,
    )

    edge, slope = PRIOR_EDGE, BEYOND_TOLERANCE_SLOPE
    white = np.array([-edge - 1.0, -edge, -1.0, 0.0, 1.0, edge, edge + 1e-9, edge + 1.0])
    expected = [-edge - slope, -edge, -1.0, 0.0, 1.0, edge, edge, edge + slope]
    assert prior_residual(white) == pytest.approx(expected, abs=1e-6)
    assert slope > 1.0 and edge >= 1.0


def test_the_air_beyond_its_tolerance_is_more_air_only_where_the_air_shows() -> None:
    """A calibrated fraction 2.6 times the rig file's (its tolerance 100 %, its band about 8
    times): beside a verdict whose pair with entrained air cuts what it leaves, more air,
    bleed; where nothing shows the air (a none, a single whose pair with air explains no
    more), the calibrated fraction is one compliance among the others and is not said."""
    rig = load_rig(RIG_FILE)
    calibration = _calibration(rig, {})
    parameters = {"calibration.air_fraction": 2.6}
    _, shown, words = for_verdict(
        calibration, parameters, ("thermal_drift",), 1.0e6, air_shown=True
    )
    assert shown is not None and shown["state"] == "more_than_rig_file", shown
    assert "bleed the brake" in words
    for effects in ((), ("thermal_drift",)):
        assert for_verdict(calibration, parameters, effects, 1.0e6) == ([], None, "")
    far = {"calibration.air_fraction": 9.0}  # outside its band as any rig value
    _, alone, _ = for_verdict(calibration, far, (), 1.0e6)
    assert alone is not None and alone["state"] == "more_than_rig_file"
