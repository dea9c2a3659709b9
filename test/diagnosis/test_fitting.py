"""A fit that meets a model its simulation cannot carry (not finite) comes back, never crashes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from brake_hil.diagnosis.calibration import calibrate
from brake_hil.diagnosis.candidates.base import Candidate, CandidateParameter, Context, Draft
from brake_hil.diagnosis.dataset import prepare
from brake_hil.diagnosis.engine import LINE_DROP, State, Step, Term
from brake_hil.diagnosis.fitting import Model, fit
from brake_hil.errors import FitError
from brake_hil.io.recording_reader import read_recording
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.physics.rig import load_rig
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

    (Before: the start was refused, or a later Jacobian's NaN stopped the whole diagnosis
    in the solver's SVD: family b, seed 1601, case 89.)
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
