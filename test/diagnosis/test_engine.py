"""The candidate simulator: exact for the LTI model, exact while a Jenkins seal sticks."""

from __future__ import annotations

import numpy as np
import pytest

from brake_hil.analysis.comparison import predict
from brake_hil.diagnosis.candidates.orifice_flow import QuadraticDrop
from brake_hil.diagnosis.candidates.thermal_drift import LINEAR, HeatingDrift
from brake_hil.diagnosis.engine import FrictionElement, MidStep, ModelSpec, simulate_batch
from brake_hil.diagnosis.engine.plant import Coupling, build_plant
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
    spec = ModelSpec(
        (params,), (HeatingDrift(np.zeros(1), np.zeros(1), np.zeros(1), np.full(1, 15.0)),)
    )
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


def test_mid_step_extrapolates_a_ramp_and_holds_at_a_turn_or_an_oscillation() -> None:
    mid = MidStep()
    ramp = [mid(np.array([v])) for v in (1.0, 2.0, 3.0, 4.0)]
    assert [float(v[0]) for v in ramp] == [1.0, 2.0, 3.5, 4.5]  # y_k + slope / 2 from the third
    turn = MidStep()
    assert [float(turn(np.array([v]))[0]) for v in (1.0, 2.0, 3.0, 2.5)][-1] == 2.5
    zigzag = MidStep()
    assert [float(zigzag(np.array([v]))[0]) for v in (0.0, 1.0, 0.0, 1.0)] == [0.0, 1.0, 0.0, 1.0]
    limited = MidStep()  # the smaller of two slopes of one sign
    assert [float(limited(np.array([v]))[0]) for v in (0.0, 1.0, 4.0)][-1] == 4.5


def test_a_turbulent_valve_is_stepped_to_second_order(default_rig: Rig, rig_input) -> None:  # type: ignore[no-untyped-def]
    """The valve's drop is taken at the mid-step flow: halving the step quarters the error.

    Held at the step's start it lags half a step (first order: the error only halves), a
    phase error a fit then took up with a delay or a hose. Most of the line's drop turbulent.
    """
    time, pressure = rig_input
    params = derive_parameters(default_rig, 1.08e6)
    params = params.with_changes(line_resistance=0.1 * params.line_resistance)
    step = float(time[1] - time[0])

    def run(substeps: int, coefficient: float) -> np.ndarray:
        fine = np.arange(0.0, time[-1] + 1e-12, step / substeps)
        spec = ModelSpec((params,), (QuadraticDrop(np.array([coefficient])),))
        outputs = simulate_batch(spec, np.interp(fine, time, pressure), step / substeps)[0]
        return outputs[:, ::substeps][:, : time.size]

    for coefficient in (3e16, 3e17):  # 3e17: ten times the drop, still stable
        reference = run(32, coefficient)
        errors = [
            np.max(np.abs(run(n, coefficient) - reference) / np.ptp(reference, axis=1)[:, None])
            for n in (1, 2)
        ]
        assert np.isfinite(errors[0]) and errors[0] / errors[1] > 3.0, errors


def _bore_response(default_rig: Rig, coupling: Coupling, hz: float) -> complex:
    """p_b / p_i of the linear plant at ``hz`` (complex gain)."""
    plant = build_plant(derive_parameters(default_rig, 1.08e6), coupling)
    n = plant.A.shape[0]
    state = np.linalg.solve(2j * np.pi * hz * np.eye(n) - plant.A, plant.B)
    return complex(plant.C[0] @ state)


def test_a_creeping_hose_wall_stores_every_volume_the_node_takes(default_rig: Rig) -> None:
    """Node balance: Q_p - Q_h = C_h p_h' + C_d p_r' in every state (scaled rows of A)."""
    coupling = Coupling(hose_compliance=4e-15, hose_creep_compliance=3e-15, hose_creep_time=0.02)
    plant = build_plant(derive_parameters(default_rig, 1.08e6), coupling)
    i, s = plant.index, plant.scale
    stored = 4e-15 * s[i["p_h"]] * plant.A[i["p_h"]] + 3e-15 * s[i["p_r"]] * plant.A[i["p_r"]]
    inflow = np.zeros_like(stored)
    inflow[i["Q_p"]], inflow[i["Q_h"]] = s[i["Q_p"]], -s[i["Q_h"]]
    assert np.allclose(stored, inflow, rtol=1e-9, atol=1e-9 * np.max(np.abs(inflow)))


def test_a_creeping_hose_wall_lies_between_its_instant_and_its_full_compliance(
    default_rig: Rig,
) -> None:
    """Creep far faster than the 5 Hz excitation is the full compliance C_h + C_d; far
    slower, the instant C_h alone; between, a lag neither gives."""
    instant, retarded = 4e-13, 8e-13

    def response(creep_time: float | None, compliance: float = instant) -> complex:
        coupling = Coupling(
            hose_compliance=compliance,
            hose_creep_compliance=None if creep_time is None else retarded,
            hose_creep_time=creep_time or 0.02,
        )
        return _bore_response(default_rig, coupling, 5.0)

    full, alone = response(None, instant + retarded), response(None)
    assert abs(response(1e-6) - full) < 1e-3 * abs(full)
    assert abs(response(1e3) - alone) < 1e-3 * abs(alone)
    between = response(0.03)
    assert min(abs(between - full), abs(between - alone)) > 1e-3 * abs(alone)
    assert np.angle(full) < np.angle(alone)  # more compliance: more lag


def test_a_reading_through_a_mode_keeps_the_static_value_and_amplifies_below_it() -> None:
    """``ChannelReading``: unit static gain; at 5 Hz through a 36 Hz mode of damping 0.1 the
    channel comes out ``|H(j w)|`` times larger and later, as the continuous system does
    (``scipy.signal.lsim``); the other channels are untouched."""
    import scipy.signal

    from brake_hil.diagnosis.engine import ChannelReading

    dt, f_n, zeta = 1e-3, 36.0, 0.1
    time = np.arange(0.0, 4.0, dt)
    signal = 2.0e6 + 1.0e6 * np.sin(2 * np.pi * 5.0 * time)
    outputs = np.stack([signal, signal, np.full_like(time, 3.0e-5)])[None].copy()
    reading = ChannelReading(0, np.array([f_n]), np.array([zeta]))
    read = reading.transform(outputs.copy(), dt)
    np.testing.assert_array_equal(read[0, 1:], outputs[0, 1:])
    steady = time > 2.0  # the start-up ring decays within 5 / (zeta w) = 0.2 s
    response = 1.0 / (1.0 - (5.0 / f_n) ** 2 + 2j * zeta * 5.0 / f_n)
    amplitude = np.ptp(read[0, 0, steady]) / np.ptp(signal[steady])
    assert amplitude == pytest.approx(abs(response), rel=1e-3)  # 1.02 times larger
    omega = 2 * np.pi * f_n
    system = ([omega**2], [1.0, 2 * zeta * omega, omega**2])
    _, continuous, _ = scipy.signal.lsim(system, signal, time, X0=None)
    reference = np.asarray(continuous) + 0.0
    # lsim starts from rest at zero: compare once both rings have died out
    assert np.max(np.abs(read[0, 0, steady] - reference[steady])) < 2e-3 * np.ptp(signal)
    constant = np.full((1, 3, 500), 7.0)
    np.testing.assert_allclose(reading.transform(constant, dt), 7.0)


def test_leading_every_output_undoes_an_input_acquired_late_through_its_filter() -> None:
    """``LeadingOutputs``: a model driven by a ``p_i`` read 3 ms late through a 1 ms first-order
    filter predicts every output late; advanced 3 ms and led 1 ms, the prediction is back on
    time within 1 % of its swing at 5 Hz (from 5.6 % off), nearer than advanced alone."""
    import scipy.signal

    from brake_hil.diagnosis.engine import LeadingOutputs

    dt, late, filter_time = 1e-3, 3e-3, 1e-3
    time = np.arange(0.0, 3.0, dt)
    on_time = 2.0e6 + 1.0e6 * np.sin(2 * np.pi * 5.0 * time)
    delayed = np.interp(time - late, time, on_time)
    pole = np.exp(-dt / filter_time)
    read = scipy.signal.lfilter([1 - pole], [1, -pole], delayed, zi=[pole * delayed[0]])[0]
    outputs = np.stack([read, read, read])[None].copy()
    led = LeadingOutputs(np.array([late]), np.array([filter_time])).transform(outputs.copy(), dt)
    inside = (time > 0.5) & (time < 2.9)  # the filter settled; the last 3 ms hold their value
    swing = np.ptp(on_time)
    assert np.max(np.abs(read[inside] - on_time[inside])) > 0.05 * swing
    for channel in range(3):
        assert np.max(np.abs(led[0, channel, inside] - on_time[inside])) < 0.01 * swing
    advanced = LeadingOutputs(np.array([late]), np.array([0.0])).transform(outputs.copy(), dt)
    assert np.max(np.abs(advanced[0, 0, inside] - on_time[inside])) > np.max(
        np.abs(led[0, 0, inside] - on_time[inside])
    )


def test_stacked_exponentials_are_scipys_one_by_one(default_rig: Rig) -> None:
    """The schedule tables' batched expm agrees with scipy's on real and random blocks.

    Real: the discretisation blocks of the seed rig's plant, plain and with a creeping hose
    node (norms in the thousands: many squarings); random: 1-norms from 0.01 to 100 (no
    squaring to seven).
    """
    import scipy.linalg

    from brake_hil.diagnosis.engine.plant import discretize_stack, expm_stack

    params = derive_parameters(default_rig, 1.08e6)
    plants = [
        build_plant(params, Coupling(line_factor=f, stiffness_factor=2.0 - f))
        for f in (0.5, 1.0, 1.5)
    ]
    hose = Coupling(
        hose_compliance=0.5 * params.bore_compliance,
        hose_creep_compliance=0.2 * params.bore_compliance,
    )
    plants_with_hose = [build_plant(params, hose)] * 2
    for stack in (plants, plants_with_hose):
        phi = discretize_stack(stack, 1e-3)[0]
        for plant, table in zip(stack, phi):
            exact = scipy.linalg.expm(plant.A * 1e-3)
            assert np.max(np.abs(table - exact)) < 1e-9 * np.max(np.abs(exact))
    rng = np.random.default_rng(7)
    blocks = rng.normal(size=(64, 9, 9)) * rng.uniform(0.003, 12.0, size=(64, 1, 1))
    exact = np.array([scipy.linalg.expm(b) for b in blocks])
    scale = np.max(np.abs(exact), axis=(1, 2))
    assert np.all(np.max(np.abs(expm_stack(blocks) - exact), axis=(1, 2)) < 1e-11 * scale)


def test_windows_run_as_one_batch_are_each_run_alone(default_rig: Rig, rig_input) -> None:  # type: ignore[no-untyped-def]
    """A time-scheduled batch whose sets start at their own times (the fit's windows).

    Each set's schedule table covers only the blocks its own stretch reaches. Reference:
    the same stretch run alone from within the first block, the drift's zero moved back by
    the whole blocks its start was moved (the schedule's times move with it exactly).
    """
    _, pressure = rig_input
    params = derive_parameters(default_rig, 1.08e6)
    stretch = pressure[:2400]
    starts = np.array([0.25, 7.5, 13.25])

    def drift(rows: int, reference: float) -> HeatingDrift:  # linear: moves with the times
        rates = (np.full(rows, 0.02), np.full(rows, -0.015))
        return HeatingDrift(*rates, np.full(rows, reference), np.full(rows, LINEAR))

    together = simulate_batch(
        ModelSpec((params,) * 3, (drift(3, 6.0),)),
        np.tile(stretch, (3, 1)),
        1e-3,
        start_time=starts,
    )
    for row, start in enumerate(starts):
        shift = float(np.floor(start))
        alone = simulate_batch(
            ModelSpec((params,), (drift(1, 6.0 - shift),)), stretch, 1e-3, start_time=start - shift
        )[0]
        span = np.ptp(alone, axis=1)[:, None]
        assert np.max(np.abs(together[row] - alone) / span) < 1e-6
    assert np.max(np.abs(together[0] - together[2]) / np.ptp(together[0], axis=1)[:, None]) > 1e-4
