"""The candidate simulator: exact for the LTI model, exact while a Jenkins seal sticks."""

from __future__ import annotations

import numpy as np
import pytest

from brake_hil.analysis.comparison import predict
from brake_hil.diagnosis.candidates.orifice_flow import QuadraticDrop
from brake_hil.diagnosis.candidates.thermal_drift import LinearDrift
from brake_hil.diagnosis.engine import FrictionElement, ModelSpec, simulate_batch
from brake_hil.physics.excitation import pulsing_profile
from brake_hil.physics.parameters import derive_parameters
from brake_hil.physics.rig import Rig


@pytest.fixture(scope="module")
def rig_input() -> tuple[np.ndarray, np.ndarray]:
    return pulsing_profile((1.38e6,), pulsing_s=2.0)


def test_linear_spec_equals_the_lti_model(default_rig: Rig, rig_input) -> None:  # type: ignore[no-untyped-def]
    _, pressure = rig_input
    params = derive_parameters(default_rig, 1.08e6)
    reference = np.array(list(predict(pressure, params).values()))
    outputs = simulate_batch(ModelSpec((params,)), pressure, 1e-3)[0]
    assert np.max(np.abs(outputs - reference) / np.ptp(reference, axis=1)[:, None]) < 1e-9


def test_stepping_loop_equals_the_lti_model_when_no_term_acts(default_rig: Rig, rig_input) -> None:  # type: ignore[no-untyped-def]
    """A drift rate of zero forces the per-step loop; it must still be the LTI model."""
    _, pressure = rig_input
    params = derive_parameters(default_rig, 1.08e6)
    reference = np.array(list(predict(pressure, params).values()))
    spec = ModelSpec((params,), (LinearDrift(np.zeros(1), np.zeros(1), np.zeros(1)),))
    outputs = simulate_batch(spec, pressure, 1e-3)[0]
    assert np.max(np.abs(outputs - reference) / np.ptp(reference, axis=1)[:, None]) < 1e-9


def test_a_jenkins_seal_that_never_slips_is_a_spring(default_rig: Rig, rig_input) -> None:  # type: ignore[no-untyped-def]
    _, pressure = rig_input
    params = derive_parameters(default_rig, 1.08e6)
    spring = 3.0e6
    stuck = ModelSpec(
        (params,),
        (
            FrictionElement(
                spring=np.array([spring]),
                apply_threshold=np.array([1e9]),
                release_threshold=np.array([1e9]),
            ),
        ),
    )
    stiffer = params.with_changes(
        effective_hydraulic_stiffness=params.effective_hydraulic_stiffness + spring
    )
    reference = np.array(list(predict(pressure, stiffer).values()))
    outputs = simulate_batch(stuck, pressure, 1e-3)[0]
    assert np.max(np.abs(outputs - reference) / np.ptp(reference, axis=1)[:, None]) < 1e-9


def test_a_slipping_seal_softens_the_caliper_and_bends_its_waveform(
    default_rig: Rig, rig_input
) -> None:  # type: ignore[no-untyped-def]
    time, pressure = rig_input
    params = derive_parameters(default_rig, 1.08e6).with_changes(
        effective_hydraulic_stiffness=0.0, effective_hydraulic_damping=1e4
    )
    thresholds = np.array([50.0, 5000.0])
    spec = ModelSpec(
        (params, params),
        (
            FrictionElement(
                spring=np.full(2, 2.3e7),
                apply_threshold=thresholds,
                release_threshold=thresholds,
            ),
        ),
    )
    outputs = simulate_batch(spec, pressure, 1e-3)
    steady = time > 2.0
    low, high = (np.ptp(outputs[b, 2, steady]) for b in range(2))
    assert low > 1.05 * high  # a seal that slips early carries less of the caliper's load


def test_batch_rows_are_independent(default_rig: Rig, rig_input) -> None:  # type: ignore[no-untyped-def]
    _, pressure = rig_input
    params = derive_parameters(default_rig, 1.08e6)
    one = simulate_batch(ModelSpec((params,), (QuadraticDrop(np.array([3e16])),)), pressure, 2e-3)
    two = simulate_batch(
        ModelSpec((params, params), (QuadraticDrop(np.array([0.0, 3e16])),)), pressure, 2e-3
    )
    assert np.allclose(two[1], one[0])
    assert not np.allclose(two[0], one[0])
