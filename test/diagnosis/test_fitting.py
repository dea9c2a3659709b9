"""A fit that meets a model its simulation cannot carry (not finite) comes back, never crashes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from brake_hil.diagnosis.calibration import calibrate
from brake_hil.diagnosis.candidates.base import Candidate, CandidateParameter, Context, Draft
from brake_hil.diagnosis.dataset import prepare
from brake_hil.diagnosis.engine import LINE_DROP, State, Step, Term
from brake_hil.diagnosis.fitting import Model, fit, fit_from_both
from brake_hil.errors import FitError
from brake_hil.io.recording_reader import read_recording
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.physics.rig import Rig, load_rig
from brake_hil.types import FloatArray
from test.conftest import PROJECT

BAG = PROJECT / "bags" / "one_washer_lti"
EDGE = 0.5  # the level above which the test term's simulation is not finite


@dataclass(frozen=True, eq=False)
class _Cliff(Term, Step):
    """No drop at all below ``EDGE``; above it the simulation is not finite."""

    level: FloatArray

    def start(self, state: State) -> Step:
        return self

    def inputs(self, state: State, explicit: FloatArray) -> None:
        explicit[:, LINE_DROP] += np.where(self.level > EDGE, np.nan, 0.0)


class _CliffCandidate(Candidate):
    """Stands beside a cliff: the Jacobian's forward step from its start falls over it."""

    entry = CATALOGUE["orifice_flow"]
    parameters = (CandidateParameter("level", "-", 0.0, 1.0, EDGE - 1e-4),)

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        draft.add(_Cliff(theta[:, 0].copy()))


class _OverTheCliff(_CliffCandidate):
    parameters = (CandidateParameter("level", "-", 0.0, 1.0, 0.9),)


@pytest.fixture(scope="module")
def lti_model() -> tuple[object, object]:
    rig = load_rig(BAG.with_suffix(".rig.yaml"))
    dataset = prepare(read_recording(BAG), rig)
    return calibrate(dataset, rig), dataset


def test_a_fit_whose_jacobian_steps_over_where_the_model_is_not_finite_is_still_fitted(
    lti_model: tuple[object, object],
) -> None:
    """The start is finite, its forward step is not: the search steps back, no crash.

    Neither is the start refused, nor does a later Jacobian's NaN stop the whole diagnosis in
    the solver's SVD.
    """
    calibration, dataset = lti_model
    model = Model(calibration, [_CliffCandidate()], dataset)  # type: ignore[arg-type]
    fitted = fit(model)
    assert fitted.theta[0] <= EDGE
    assert np.isfinite(fitted.held_out_cost) and np.isfinite(fitted.train_cost)
    assert fitted.uncertainty is None or np.all(np.isfinite(fitted.uncertainty))


def test_a_fit_that_is_not_finite_where_it_starts_is_a_fit_error(
    lti_model: tuple[object, object],
) -> None:
    calibration, dataset = lti_model
    model = Model(calibration, [_OverTheCliff()], dataset)  # type: ignore[arg-type]
    with pytest.raises(FitError, match="not finite where its fit starts"):
        fit(model)


def test_a_late_input_is_fitted_to_the_noise_reading_the_run_past_its_window(
    default_rig: Rig, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every output leading alike (``p_i`` acquired 3 ms late) advances the run: the last
    milliseconds of each window come from past its end. Held at the run's final value
    instead, the few samples at each window's end leave many times the noise on a late
    ``p_i`` (about 20 times on family a), and a hose fits better. Fitted as the diagnosis fits
    a single (:func:`fit_from_both`: from the calibration and from the rig file's values; the
    calibration, bent to lag the outputs, is a start the fit does not leave)."""
    from brake_hil.diagnosis.candidates import candidate
    from brake_hil.virtual_rig.effects import make_effect
    from brake_hil.virtual_rig.excitation import seed_pulsing
    from brake_hil.virtual_rig.simulator import simulate_rig

    late = make_effect("sensor_delay", 1.0, channel="p_i", delay=3.0e-3)
    run = simulate_rig(default_rig, [late], seed_pulsing((1.38e6, 2.76e6), pulsing_s=3.0), seed=7)
    dataset = prepare(run.as_recording(), default_rig)
    calibration = calibrate(dataset, default_rig)
    delay = [candidate("sensor_delay")]
    fitted = fit_from_both(Model(calibration, delay, dataset))
    assert Model(calibration, delay, dataset).lookahead >= 0.02
    assert fitted.held_out_cost < 3.0 * dataset.noise_cost()
    assert max(fitted.theta[:3]) < -2.5e-3  # every output leads by about the delay
    monkeypatch.setattr(type(delay[0]), "lookahead", 0.0)
    held = fit_from_both(Model(calibration, delay, dataset))
    assert held.held_out_cost > 3.0 * fitted.held_out_cost


def test_a_single_is_also_fitted_from_the_rig_files_values_when_the_calibration_moved_far(
    default_rig: Rig,
) -> None:
    """``x_c`` acquired 3 ms late: the calibration lags it by lowering the caliper's stiffness
    and force area (about 1.9 sigmas each), and a delay fitted from there stays near it (a
    0.3 ms delay of ``p_b`` and 0.7 ms of ``F_k`` beside x_c's). Fitted from the rig file's
    values too, the better fit is the truth: x_c late, the others on time."""
    from brake_hil.diagnosis.candidates import candidate
    from brake_hil.diagnosis.fitting import RESTART_SIGMAS, fit_from_both
    from brake_hil.virtual_rig.effects import make_effect
    from brake_hil.virtual_rig.excitation import seed_pulsing
    from brake_hil.virtual_rig.simulator import simulate_rig

    late = make_effect("sensor_delay", 0.75, channel="x_c")
    pulsing = seed_pulsing((1.38e6, 2.07e6, 2.76e6), pulsing_s=3.0)
    dataset = prepare(
        simulate_rig(default_rig, [late], pulsing, seed=25).as_recording(), default_rig
    )
    calibration = calibrate(dataset, default_rig)
    assert max(abs(z) for z in calibration.prior_z().values()) > RESTART_SIGMAS
    model = Model(calibration, [candidate("sensor_delay")], dataset)
    both = fit_from_both(model)
    assert both.train_cost <= fit(model).train_cost
    delays = both.parameters()
    assert delays["delay_x_c"] == pytest.approx(3.0e-3, abs=0.2e-3)
    assert max(delays["delay_p_b"], delays["delay_F_k"]) < 0.1e-3
