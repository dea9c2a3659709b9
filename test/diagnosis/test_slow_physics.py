"""Physics slower than a cycle: a seat that creeps, a rig that heats, fitted with its own times."""

from __future__ import annotations

from pathlib import Path

import pytest

from brake_hil.diagnosis.calibration import calibrate
from brake_hil.diagnosis.candidates import candidate
from brake_hil.diagnosis.dataset import prepare
from brake_hil.diagnosis.fitting import PREROLL, Fit, Model, fit
from brake_hil.physics.rig import Rig
from brake_hil.virtual_rig import make_effect, seed_pulsing, simulate_rig
from brake_hil.virtual_rig.effects.base import Effect

RELAXATION_TIME = 1.0  # s, the virtual rig's seat creep (family a's default)


def _baseline_and_fit(rig: Rig, effect: Effect, name: str, seed: int) -> tuple[Fit, Fit]:
    """The calibrated baseline and candidate ``name`` fitted on the virtual rig with ``effect``
    (the seed's three 5 s pulsing segments)."""
    run = simulate_rig(
        rig, [effect], seed_pulsing((1.38e6, 2.07e6, 2.76e6), pulsing_s=5.0), seed=seed
    )
    dataset = prepare(run.as_recording(), rig)
    calibration = calibrate(dataset, rig)
    return fit(Model(calibration, [], dataset)), fit(
        Model(calibration, [candidate(name)], dataset)
    )


def test_a_creeping_seat_is_fitted_with_its_own_creep_time(default_rig: Rig) -> None:
    """A groove whose seat creeps over 1 s, on the seed's three 5 s segments: fitted on runs
    that start 0.8 s before each window, its creep came out about 0.45 s (faster, to forget
    the run's start) and left several times the fit below; with the groove's 3 s lead-in the
    creep time is the drawn one and the asymmetry too."""
    groove = make_effect("seal_groove_asymmetry", 1.0, relaxation_time=RELAXATION_TIME)
    run = simulate_rig(
        default_rig, [groove], seed_pulsing((1.38e6, 2.07e6, 2.76e6), pulsing_s=5.0), seed=3
    )
    dataset = prepare(run.as_recording(), default_rig)
    calibration = calibrate(dataset, default_rig)
    model = Model(calibration, [candidate("seal_groove_asymmetry")], dataset)
    assert model.preroll == candidate("seal_groove_asymmetry").lead_in > PREROLL
    assert Model(calibration, [candidate("orifice_flow")], dataset).preroll == PREROLL
    fitted = fit(model).parameters()
    assert fitted["relaxation_time"] == pytest.approx(RELAXATION_TIME, rel=0.25)
    assert fitted["stiffness_asymmetry"] == pytest.approx(0.4, rel=0.2)


def test_a_rig_that_heats_up_is_fitted_with_its_heating_time(default_rig: Rig) -> None:
    """The virtual rig heating with a 15 s time constant over three 5 s segments: a drift
    linear in time left a misfit many times the one of a drift that settles as the rig's
    temperature does (first-order heating), whose heating time is the drawn one."""
    from brake_hil.diagnosis.candidates.thermal_drift import LINEAR, heated_time

    heating = make_effect("thermal_drift", 1.0, time_constant=15.0)
    baseline, drift = _baseline_and_fit(default_rig, heating, "thermal_drift", seed=4)
    fitted = drift.parameters()
    assert fitted["heating_time"] == pytest.approx(15.0, rel=0.3)
    assert fitted["line_drift_rate"] < 0 and fitted["seal_drift_rate"] < 0  # it softens
    assert baseline.held_out_cost / drift.held_out_cost > 60  # a drift linear in time: about 18
    # a model file older than the heating time reads as the linear drift it was
    assert heated_time(12.0, 5.0, LINEAR) == pytest.approx(7.0, rel=1e-6)
    assert heated_time(12.0, 5.0, 15.0) < 7.0


@pytest.mark.parametrize(
    ("family", "seed", "number", "told_apart"),
    [("c", 8403, 0, False), ("a", 8401, 1, True)],
    ids=["zeros-walking", "heating"],
)
def test_a_drift_only_the_transducers_zeros_make_is_not_told_from_them(
    tmp_path: Path, family: str, seed: int, number: int, told_apart: bool
) -> None:
    """Family c's null 000 of seed 8403 (every rig value within its tolerance; its chain walks
    the zeros of F_k and x_c by 1.5 times their noise): a thermal drift cut the held-out
    error 1.7 times and was named at 0.78. Fitted in its place, F_k's and x_c's zeros moving
    within their stability (about 1 N and 0.04 um) leave 1.2 times its error, under the 1.5
    that tells them apart: the rival check sets the drift aside. Family a's heating rig (case
    001 of seed 8401) would need zeros moving 23 N: beyond a transducer's stability, 38 times
    the drift's error; the drift passes."""
    from brake_hil.diagnosis.physics_checks import rival_check
    from brake_hil.io.recording_reader import read_recording
    from brake_hil.physics.rig import load_rig
    from brake_hil.virtual_rig.cases import make_case, plan_cases

    spec = plan_cases(56, seed, family=family)[number]
    assert [e.name for e in spec.effects] == ([] if family == "c" else ["thermal_drift"])
    make_case(spec, tmp_path, pulsing_s=5.0)
    folder = tmp_path / spec.case_id
    rig = load_rig(folder / "rig.yaml")
    dataset = prepare(read_recording(folder / "recording"), rig)
    model = Model(calibrate(dataset, rig), [candidate("thermal_drift")], dataset)
    outcome = rival_check(model, fit(model))
    assert outcome.passed == told_apart, outcome.finding
    assert "zeros moving" in outcome.finding
    if told_apart:
        assert "beyond a transducer's zero stability" in outcome.finding


def test_a_short_cocking_arm_is_fitted_as_strong_bore_friction(default_rig: Rig) -> None:
    """Bore friction whose normal force acts over the piston's 3 mm guide, not the paper's
    10 cm ``l_c`` (the virtual rig's law): the candidate's coefficient is ``mu_fb`` times
    ``l_c`` over the arm (0.8 x 0.2 x 33 here), its contact stiffer than 5e7 N/m. Held to a
    coefficient of at most 3 and that contact, the candidate cut this recording's held-out
    error 3.8 times; with both fitted, 28 times."""
    from brake_hil.diagnosis.candidates.bore_friction import CONTACT_STIFFNESS

    friction = make_effect("bore_friction", 0.8)
    baseline, fitted = _baseline_and_fit(default_rig, friction, "bore_friction", seed=5)
    values = fitted.parameters()
    assert values["bore_friction_coefficient"] > 3.0
    assert values["contact_stiffness"] > CONTACT_STIFFNESS
    assert baseline.held_out_cost / fitted.held_out_cost > 10.0


def test_a_groove_whose_fit_slides_to_no_asymmetry_is_fitted_from_its_second_start(
    tmp_path: Path,
) -> None:
    """Family a's case 016 of seed 8431, a strong groove (asymmetry 0.4, the seat creeping
    over 1 s) on a rig within its tolerances: fitted from its first start the groove slid to
    no asymmetry and an 18 s creep, cutting the held-out error 1.005 times (the verdict was
    none); from the second start (``other_starts``) it finds the groove, and the better
    training fit is kept."""
    from brake_hil.diagnosis.fitting import fit_from_both
    from brake_hil.io.recording_reader import read_recording
    from brake_hil.physics.rig import load_rig
    from brake_hil.virtual_rig.cases import make_case, plan_cases

    spec = plan_cases(56, 8431, family="a")[16]
    assert [e.name for e in spec.effects] == ["seal_groove_asymmetry"]
    make_case(spec, tmp_path, pulsing_s=5.0)
    folder = tmp_path / spec.case_id
    rig = load_rig(folder / "rig.yaml")
    dataset = prepare(read_recording(folder / "recording"), rig)
    calibration = calibrate(dataset, rig)
    baseline = fit(Model(calibration, [], dataset))
    model = Model(calibration, [candidate("seal_groove_asymmetry")], dataset)
    first = fit(model)
    assert baseline.held_out_cost / first.held_out_cost < 2.0
    both = fit_from_both(model)
    assert baseline.held_out_cost / both.held_out_cost > 20.0
    assert both.parameters()["stiffness_asymmetry"] == pytest.approx(0.4, abs=0.12)
    assert both.parameters()["relaxation_time"] == pytest.approx(RELAXATION_TIME, rel=0.25)
