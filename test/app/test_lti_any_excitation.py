"""The LTI model's own recordings of every excitation, compared with the model: exact.

``brake-hil simulate --engine lti --excitation KIND`` writes the model's answer (with the
DAQ's noise) to a pulsing, a ramp, a sweep or a whole procedure; ``compare`` on it must find
the model within 0.5 % of itself on every segment it scores.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from brake_hil.analysis.segment_comparison import compare_segments
from brake_hil.app.simulate import run_simulate
from brake_hil.cli import main
from brake_hil.errors import BrakeHilError
from brake_hil.io.recording_reader import read_recording
from brake_hil.physics.rig import load_rig
from test.conftest import CONFIG

RIG = CONFIG / "rig_default.yaml"
PRESSURES = (1.38e6, 2.07e6, 2.76e6)
RATIOS = ("ptp_ratio_pct", "map_gain_ratio_pct", "mean_gain_ratio_pct", "rise_time_ratio_pct")
"""Model over measured, in %: exact is 100."""
ERRORS = ("stick_error_pct", "level_error_pct", "loop_width_error_pct", "tau_over_T_pct")
"""Model minus measured, in % of a range or of the period: exact is 0."""


def _off_exact(metrics: dict[str, object]) -> dict[str, float]:
    """How far each figure of merit is from exact (percentage points; NRMSE in %)."""
    values = {k: float(v) for k, v in metrics.items() if isinstance(v, int | float)}
    off = {k: abs(values[k] - 100.0) for k in RATIOS if k in values}
    off.update({k: abs(values[k]) for k in ERRORS if k in values})
    if "worst_error_pct" in values:  # a sweep's worst band: |model / measured - 1|
        off["worst_error_pct"] = values["worst_error_pct"]
        off["mean_phase_error_deg"] = abs(values["mean_phase_error_deg"])
    if "nrmse" in values:
        off["nrmse_pct"] = 100.0 * values["nrmse"]
    return off


@pytest.mark.parametrize(
    ("kind", "expected"),
    [
        ("pulsing", {"pulsing"}),
        ("ramp", {"ramp", "hold"}),
        ("sweep", {"sweep"}),
        ("procedure", {"pulsing", "sweep", "ramp", "hold", "modulated", "step"}),
    ],
)
def test_compare_finds_the_lti_model_within_half_a_percent_of_itself(
    tmp_path: Path, kind: str, expected: set[str]
) -> None:
    out = tmp_path / kind
    run_simulate(RIG, out, PRESSURES, 1.5, seed=4, excitation=kind)
    comparison = compare_segments(read_recording(out), load_rig(RIG))
    scored = [s for s in comparison.segments if s.metrics]
    assert expected <= {s.segment.kind for s in scored}
    worst = {}
    for s in scored:
        for channel, metrics in s.metrics.items():
            for key, value in _off_exact(metrics).items():
                worst[(s.segment.kind, channel, key)] = max(
                    value, worst.get((s.segment.kind, channel, key), 0.0)
                )
    too_far = {key: value for key, value in worst.items() if value > 0.5}
    assert too_far == {}
    for channel, metrics in comparison.metrics().items():
        assert abs(metrics["ptp_ratio_pct"] - 100.0) < 0.5, channel
        assert metrics["nrmse"] < 0.005, channel


def test_simulate_runs_the_lti_model_on_any_pressure_input(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["simulate", "--rig", str(RIG), "--engine", "lti", "--pulsing-seconds", "1"]
    assert main([*args, "--out", str(tmp_path / "sweep"), "--excitation", "sweep"]) == 0
    recording = read_recording(tmp_path / "sweep")
    assert recording.time.size == 3001  # 1 s ramp, 2 s sweep
    assert recording.predicted_bore_pressure is None  # a measurement, not a replay
    assert main([*args, "--out", str(tmp_path / "air"), "--excitation", "solenoid"]) == 2
    assert "solenoid" in capsys.readouterr().err
    assert not (tmp_path / "air").exists()
    with pytest.raises(BrakeHilError, match="the LTI model takes"):
        run_simulate(RIG, tmp_path / "x", PRESSURES, 1.0, 0, excitation="chirp")
