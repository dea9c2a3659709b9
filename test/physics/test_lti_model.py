"""The LTI caliper model (seed eq. 21): exact discretisation against a stiff solver."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from brake_hil.physics.excitation import pulsing_profile
from brake_hil.physics.lti_model import (
    CaliperStepper,
    ModelInput,
    air_driven_state_space,
    caliper_state_space,
    discretize,
    eigenfrequencies,
    simulate,
    state_space,
)
from brake_hil.physics.parameters import derive_parameters
from brake_hil.physics.rig import Rig


def _nrmse(predicted: np.ndarray, reference: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean((predicted - reference) ** 2, axis=1)) / np.ptp(reference, axis=1)


def _stiff_reference(system, time, pressure):  # type: ignore[no-untyped-def]
    A, B, C = system.state_matrix, system.input_matrix[:, 0], system.output_matrix
    start = discretize(system).equilibrium(pressure[0]) * system.state_scale
    solution = solve_ivp(
        lambda t, x: A @ x + B * np.interp(t, time, pressure),
        (time[0], time[-1]),
        start,
        method="Radau",
        t_eval=time,
        jac=A,
        rtol=1e-6,
        atol=1e-6 * system.state_scale,
        max_step=1e-3,
    )
    assert solution.success
    return C @ solution.y


@pytest.fixture(scope="module")
def rig_input() -> tuple[np.ndarray, np.ndarray]:
    """18 s like the seed's runs: three ramps to 1.38, 2.07, 2.76 MPa then 5 Hz pulsing."""
    return pulsing_profile((1.38e6, 2.07e6, 2.76e6))


def test_rig_input_lasts_18_seconds(rig_input: tuple[np.ndarray, np.ndarray]) -> None:
    time, _ = rig_input
    assert time.size == 18000 and time[-1] == pytest.approx(17.999)


def test_batch_and_stepper_match_stiff_solver_on_rig_input(
    default_rig: Rig, rig_input: tuple[np.ndarray, np.ndarray]
) -> None:
    time, pressure = rig_input
    system = caliper_state_space(derive_parameters(default_rig, 1.6e6))
    model = discretize(system)
    reference = _stiff_reference(system, time, pressure)
    batch = simulate(model, pressure)
    stepper = CaliperStepper(model)
    stepped = np.array([stepper.step(p) for p in pressure]).T
    assert np.all(_nrmse(batch, reference) < 1e-3)
    assert np.all(_nrmse(stepped, reference) < 1e-3)
    assert np.max(np.abs(stepped - batch) / np.ptp(batch, axis=1)[:, None]) < 1e-9


def test_air_driven_model_matches_stiff_solver(default_rig: Rig) -> None:
    time = np.arange(0.0, 3.0, 1e-3)
    air = 0.15e6 + 0.04e6 * np.sin(2 * np.pi * 5.0 * time)
    system = air_driven_state_space(derive_parameters(default_rig))
    reference = _stiff_reference(system, time, air)
    assert np.all(_nrmse(simulate(discretize(system), air), reference) < 1e-3)


def test_default_rig_reproduces_the_operating_point_of_physics_md(default_rig: Rig) -> None:
    """p_i = 0.9 + 0.3 sin(10 pi t) MPa: p_b 0.61 MPa (0.41 restricted), F_k 1.26 kN, x_c 37 um."""
    time = np.arange(0.0, 4.0, 1e-3)
    pressure = 0.9e6 + 0.3e6 * np.sin(10 * np.pi * time)
    params = derive_parameters(default_rig, 0.9e6)
    steady = slice(2000, None)
    p_b, f_k, x_c = np.ptp(
        simulate(discretize(caliper_state_space(params)), pressure)[:, steady], axis=1
    )
    assert p_b == pytest.approx(0.61e6, rel=0.02)
    assert f_k == pytest.approx(1.26e3, rel=0.03)
    assert x_c == pytest.approx(37e-6, rel=0.03)
    restricted = params.with_changes(line_resistance=params.line_resistance - 3.2e10 + 1.3e11)
    p_b_restricted = np.ptp(
        simulate(discretize(caliper_state_space(restricted)), pressure)[0, steady]
    )
    assert p_b_restricted == pytest.approx(0.41e6, rel=0.02)


def test_model_is_stiff_from_17_hz_to_170_khz(default_rig: Rig) -> None:
    frequencies = eigenfrequencies(caliper_state_space(derive_parameters(default_rig)))
    assert frequencies[0] == pytest.approx(17.0, rel=0.05)
    assert frequencies[-1] == pytest.approx(1.7e5, rel=0.05)


def test_explicit_euler_at_1_khz_diverges_where_exact_discretisation_is_stable(
    default_rig: Rig,
) -> None:
    system = caliper_state_space(derive_parameters(default_rig))
    euler = np.eye(6) + system.state_matrix * 1e-3
    assert np.max(np.abs(np.linalg.eigvals(euler))) > 1.0
    assert np.max(np.abs(np.linalg.eigvals(discretize(system).transition))) < 1.0


def test_pressure_pushes_pistons_to_the_block_and_caliper_away(default_rig: Rig) -> None:
    model = discretize(caliper_state_space(derive_parameters(default_rig)))
    p_b, f_k, x_c = CaliperStepper(model).step(1.0e6)
    assert p_b == pytest.approx(1.0e6)
    assert f_k > 0.0 and x_c < 0.0


def test_stepper_starts_from_equilibrium_and_holds_it(default_rig: Rig) -> None:
    model = discretize(caliper_state_space(derive_parameters(default_rig)))
    stepper = CaliperStepper(model)
    first = stepper.step(1.2e6)
    for _ in range(50):
        later = stepper.step(1.2e6)
    assert np.allclose(first, later, rtol=1e-9)
    stepper.reset()
    assert not stepper.started


def test_state_space_picks_the_input(default_rig: Rig) -> None:
    params = derive_parameters(default_rig)
    assert state_space(params, ModelInput.AIR_PRESSURE).state_matrix.shape == (9, 9)
    assert state_space(params, ModelInput.MASTER_CYLINDER_PRESSURE).output_names == (
        "p_b",
        "F_k",
        "x_c",
    )


def test_simulate_refuses_an_empty_input(default_rig: Rig) -> None:
    model = discretize(caliper_state_space(derive_parameters(default_rig)))
    with pytest.raises(ValueError, match="non-empty"):
        simulate(model, np.array([]))
