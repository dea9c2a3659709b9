"""compare on every segment kind: the LTI model against itself, the bundled ramp and sweep,
and the steady pulsing exactly as before."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from brake_hil.analysis.comparison import compare
from brake_hil.analysis.segment_comparison import compare_segments
from brake_hil.analysis.sweep_characterization import characterize_recording
from brake_hil.errors import NoSteadyPulsingError
from brake_hil.io.opened import open_recording
from brake_hil.physics.parameters import derive_parameters
from brake_hil.virtual_rig.excitation import frequency_sweep, pressure_ramp
from test.analysis.chains import lti_recording, procedure
from test.conftest import CONFIG, PROJECT

RIG = str(CONFIG / "rig_default.yaml")
EXACT_PCT = 0.5
"""The model against itself: every ratio within this of 100 %, every error within it of 0."""


def _ramp() -> tuple[np.ndarray, np.ndarray]:
    drive = pressure_ramp(2.76e6)
    return drive.time, drive.pressure


def _sweep() -> tuple[np.ndarray, np.ndarray]:
    drive = frequency_sweep(1.08e6, 0.3e6)
    return drive.time, drive.pressure


def _procedure() -> tuple[np.ndarray, np.ndarray]:
    time, pressure, _ = procedure(11)
    return time, pressure


def _exact(kind: str, metrics: dict[str, object]) -> list[str]:
    """The metrics of one channel of one segment that are not within EXACT_PCT of exact."""
    ratios = ("ptp_ratio_pct", "gain_ratio_pct", "mean_gain_ratio_pct", "map_gain_ratio_pct")
    errors = ("tau_over_T_pct", "level_error_pct", "stick_error_pct", "loop_width_error_pct")
    errors += ("worst_error_pct", "overshoot_error_pct")
    wrong = [k for k in ratios if k in metrics and abs(float(metrics[k]) - 100.0) > EXACT_PCT]
    wrong += [k for k in errors if k in metrics and abs(float(metrics[k])) > EXACT_PCT]
    for key in ("phase_error_deg", "mean_phase_error_deg"):  # 0.5 % of a cycle
        if key in metrics and abs(float(metrics[key])) > 3.6 * EXACT_PCT:
            wrong.append(key)
    if kind == "step" and abs(float(metrics["rise_time_ratio_pct"]) - 100.0) > 5.0:
        wrong.append("rise_time_ratio_pct")  # a rise of ~20 samples: one sample is 5 %
    return wrong


@pytest.mark.parametrize("drive", [_ramp, _sweep, _procedure], ids=["ramp", "sweep", "procedure"])
def test_the_model_against_its_own_recording_is_exact_on_every_segment(drive) -> None:  # type: ignore[no-untyped-def]
    rig, recording = lti_recording(RIG, *drive(), seed=21)
    comparison = compare_segments(recording, rig)
    scored = [s for s in comparison.segments if s.metrics]
    assert len(scored) >= 2
    for s in scored:
        for channel, metrics in s.metrics.items():
            assert not _exact(s.segment.kind, metrics), (s.segment, channel, metrics)
    for channel, m in comparison.metrics().items():
        assert abs(m["ptp_ratio_pct"] - 100.0) <= EXACT_PCT, (channel, m)
        assert abs(m["tau_over_T_pct"]) <= EXACT_PCT, (channel, m)
        assert m["nrmse"] <= 0.005, (channel, m)


def test_a_wrong_model_is_not_exact() -> None:
    """The check above can fail: a caliper 30 % stiffer than recorded shows in x_c."""
    rig, recording = lti_recording(RIG, *_sweep(), seed=22)
    stiffer = dataclasses.replace(rig, caliper_stiffness=1.3 * rig.caliper_stiffness)
    comparison = compare_segments(recording, stiffer)
    sweep = next(s for s in comparison.segments if s.segment.kind == "sweep")
    assert _exact("sweep", sweep.metrics["x_c"])
    assert float(sweep.metrics["x_c"]["mean_gain_ratio_pct"]) < 95.0


@pytest.mark.parametrize("name", ["ramp_one_washer", "sweep_one_washer"])
def test_the_bundled_ramp_and_sweep_are_compared_per_segment(name: str) -> None:
    opened = open_recording(PROJECT / "bags" / name, None)
    comparison = compare_segments(opened.recording, opened.rig)
    document = comparison.as_dict()
    assert document["basis"] == "non_idle_segments"
    kinds = [s["kind"] for s in document["segments"]]
    wanted = ["idle", "ramp", "hold", "ramp", "idle"] if "ramp" in name else ["ramp", "sweep"]
    assert kinds == wanted
    for channel, m in document["metrics"].items():
        assert {"ptp_ratio_pct", "tau_over_T_pct", "nrmse"} <= set(m), channel
    p_b = document["metrics"]["p_b"]  # the bore pressure follows p_i closely on this rig
    assert 97.0 < p_b["ptp_ratio_pct"] < 103.0 and p_b["nrmse"] < 0.05
    if "sweep" in name:
        sweep = document["segments"][1]
        assert 4.5 < sweep["f0_hz"] < 5.5 and 24.5 < sweep["f1_hz"] < 25.5
        response = sweep["metrics"]["F_k"]["response"]
        assert [p["frequency_hz"] for p in response] == list(np.arange(6.0, 25.0))
        assert 5.0 < sweep["metrics"]["F_k"]["worst_hz"] < 25.0
    else:  # the seal sticks: the measured loop is wider than the LTI model's
        fall = document["segments"][3]
        assert (
            fall["metrics"]["F_k"]["loop_width_measured"]
            > fall["metrics"]["F_k"]["loop_width_model"]
        )


@pytest.mark.parametrize("name", ["one_washer_open", "one_washer_lti", "effect_sensor_delay"])
def test_steady_pulsing_is_scored_exactly_as_before(name: str) -> None:
    opened = open_recording(PROJECT / "bags" / name, None)
    before = compare(opened.recording, opened.rig).as_dict()
    after = compare_segments(opened.recording, opened.rig).as_dict()
    assert after["metrics"] == before["metrics"] and after["basis"] == "steady_cycles"
    steady = [s for s in after["segments"] if s["steady"]]  # type: ignore[index]
    assert [
        {key: s[key] for key in ("t_start", "t_end", "mean_pressure", "metrics")} for s in steady
    ] == before["segments"]
    assert all(s["kind"] == "pulsing" and s["frequency_hz"] == 5.0 for s in steady)


def test_characterize_on_an_lti_sweep_returns_the_rig_files_seal_at_every_frequency() -> None:
    rig, recording = lti_recording(RIG, *_sweep(), seed=23)
    found = characterize_recording(recording, rig)
    assert not found.steady and len(found.sweeps) == 1
    params = derive_parameters(rig)
    bands = found.sweeps[0].bands
    assert [b.frequency_hz for b in bands] == list(np.arange(6.0, 25.0))
    for band in bands:
        assert band.k_eh == pytest.approx(params.effective_hydraulic_stiffness, rel=0.02)
        assert band.c_eh == pytest.approx(params.effective_hydraulic_damping, rel=0.02)
        assert 0 < band.k_eh_sigma < 0.02 * band.k_eh and 0 < band.c_eh_sigma < 0.02 * band.c_eh
        omega = 2 * np.pi * band.frequency_hz
        assert band.eta_eh == pytest.approx(band.c_eh * omega / band.k_eh)


def test_characterize_on_a_ramp_says_it_needs_pulsing_or_a_sweep() -> None:
    opened = open_recording(PROJECT / "bags" / "ramp_one_washer", None)
    with pytest.raises(NoSteadyPulsingError, match="needs steady pulsing at 5 Hz or a sweep"):
        characterize_recording(opened.recording, opened.rig)


def test_characterize_on_the_bundled_sweep_gives_a_point_per_band(tmp_path: Path) -> None:
    opened = open_recording(PROJECT / "bags" / "sweep_one_washer", None)
    found = characterize_recording(opened.recording, opened.rig)
    bands = found.sweeps[0].bands
    assert len(bands) == 19
    # the seal sticks and slips: its equivalent damping falls with frequency (friction)
    assert bands[-1].c_eh < 0.5 * bands[0].c_eh
    assert all(b.k_eh > 0 and b.k_eh_sigma > 0 for b in bands)
