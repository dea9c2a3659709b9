"""Characterisation (seed eqs. 1, 3-11) recovers what a synthetic recording was made with."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from brake_hil.analysis.characterization import characterize, jenkins_loop_area, loop_area
from brake_hil.analysis.comparison import predict
from brake_hil.analysis.recording import Recording
from brake_hil.errors import RecordingError
from brake_hil.physics.excitation import pulsing_profile
from brake_hil.physics.measurement import SENSORS, measure
from brake_hil.physics.parameters import derive_parameters, seal_properties
from brake_hil.physics.rig import Rig


def _lti_recording(rig: Rig, k_eh: float, c_eh: float, seed: int = 3) -> Recording:
    time, pressure = pulsing_profile((1.38e6, 2.76e6), pulsing_s=4.0)
    params = derive_parameters(rig, 1.3e6).with_changes(
        effective_hydraulic_stiffness=k_eh, effective_hydraulic_damping=c_eh
    )
    outputs = predict(pressure, params)
    rng = np.random.default_rng(seed)
    return Recording(
        path=Path("synthetic"),
        time=time,
        master_cylinder_pressure=measure(pressure, SENSORS["p_i"], rng),
        bore_pressure=measure(outputs["p_b"], SENSORS["p_b"], rng),
        block_force=measure(outputs["F_k"], SENSORS["F_k"], rng),
        caliper_displacement=measure(outputs["x_c"], SENSORS["x_c"], rng),
    )


@pytest.mark.parametrize(("k_eh", "c_eh"), [(6.75e6, 2.0e5), (3.0e6, 0.6e5), (1.2e7, 1.5e5)])
def test_recovers_known_k_eh_and_c_eh_of_a_noisy_lti_recording(
    default_rig: Rig, k_eh: float, c_eh: float
) -> None:
    segments = characterize(_lti_recording(default_rig, k_eh, c_eh), default_rig)
    assert len(segments) == 2
    for segment in segments:
        assert segment.k_eh == pytest.approx(k_eh, rel=0.02)
        assert segment.c_eh == pytest.approx(c_eh, rel=0.02)


def test_normalised_quantities_follow_their_definitions(default_rig: Rig) -> None:
    segment = characterize(_lti_recording(default_rig, 6.75e6, 2.0e5), default_rig)[0]
    k_s = seal_properties(default_rig).static_stiffness
    assert segment.k_eh_star == pytest.approx(0.5 * segment.k_eh / k_s)
    assert segment.eta_eh == pytest.approx(segment.c_eh * 2 * np.pi * 5.0 / segment.k_eh)
    assert segment.xi == pytest.approx(
        segment.two_c_fs_star + segment.two_c_ss_star + segment.two_c_fb_star
    )
    assert segment.max_pressure == pytest.approx(1.38e6, rel=0.01)
    assert segment.seal_slips  # 2 X_s ~ 39 um > c_s = 13.4 um, as in the seed
    assert segment.harmonic_energy_pct["p_b"][0] > 99.9  # an LTI model adds no harmonics


def test_seed_operating_point_gives_seal_coulomb_damping_near_the_measured(
    default_rig: Rig,
) -> None:
    """The seed's 1A point: 2 c_fs* = 0.97; the LTI default rig lands within 10 %."""
    segment = characterize(_lti_recording(default_rig, 6.75e6, 2.0e5), default_rig)[0]
    assert segment.two_c_fs_star == pytest.approx(0.97, rel=0.1)


def _jenkins_force(displacement: np.ndarray, stiffness: float, threshold: float) -> np.ndarray:
    force = np.empty_like(displacement)
    slider = 0.0
    for k, x in enumerate(displacement):
        trial = stiffness * (x - slider)
        if abs(trial) > threshold:
            slider = x - np.sign(trial) * threshold / stiffness
            trial = np.sign(trial) * threshold
        force[k] = trial
    return force


def test_loop_area_of_a_stick_slip_jenkins_loop_matches_4_f_fs_x_minus_c_s(
    default_rig: Rig,
) -> None:
    seal = seal_properties(default_rig)
    amplitude = 2.5 * seal.slip_threshold
    time = np.arange(0.0, 1.0, 1e-3)
    displacement = amplitude * np.sin(2 * np.pi * 5.0 * time)
    force = _jenkins_force(displacement, seal.static_stiffness, seal.friction_threshold)
    steady = slice(200, 1000)  # four whole cycles after the first
    measured = loop_area(displacement[steady], force[steady]) / 4.0
    expected = jenkins_loop_area(seal.friction_threshold, seal.slip_threshold, amplitude)
    assert measured == pytest.approx(expected, rel=0.02)
    assert jenkins_loop_area(seal.friction_threshold, seal.slip_threshold, 0.5e-6) == 0.0


def test_viscous_loop_area_is_pi_c_w_x_squared() -> None:
    time = np.arange(0.0, 0.2, 1e-4)
    omega = 2 * np.pi * 5.0
    x = 1e-5 * np.sin(omega * time)
    force = 2e6 * x + 1e5 * np.gradient(x, time)
    assert loop_area(x, force) == pytest.approx(np.pi * 1e5 * omega * 1e-10, rel=0.01)


def test_characterisation_needs_every_measured_channel(default_rig: Rig) -> None:
    recording = _lti_recording(default_rig, 6.75e6, 2.0e5)
    without_force = Recording(
        path=Path("no-force.mcap"),
        time=recording.time,
        master_cylinder_pressure=recording.master_cylinder_pressure,
        bore_pressure=recording.bore_pressure,
        caliper_displacement=recording.caliper_displacement,
    )
    with pytest.raises(RecordingError, match="no-force.mcap: characterisation needs measured F_k"):
        characterize(without_force, default_rig)
