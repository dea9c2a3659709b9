"""The doors as the commands use them: the recording's own rate, tolerance 0, named errors."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from brake_hil.analysis.recording import Recording
from brake_hil.app.naming import naming
from brake_hil.app.regress import replay_recording
from brake_hil.diagnosis.calibration import uncertain_values
from brake_hil.errors import RecordingError, SignalError
from brake_hil.physics.rig import load_rig
from test.conftest import CONFIG, PROJECT
from test.hostile import damage

RIG = CONFIG / "rig_default.yaml"


def _decimated(step: int) -> Recording:
    from brake_hil.io.recording_reader import read_recording

    recording = read_recording(damage.GOOD_BAG)
    fields = (
        "time",
        "master_cylinder_pressure",
        "bore_pressure",
        "block_force",
        "caliper_displacement",
    )
    return replace(recording, **{name: getattr(recording, name)[::step] for name in fields})


def test_regress_refuses_a_recording_the_live_model_cannot_replay_at_its_rate() -> None:
    """The live model steps at 1 kHz; a 250 Hz recording would replay 4x too slow."""
    with pytest.raises(RecordingError, match="250 Hz; the live model steps at 1000 Hz"):
        replay_recording(_decimated(4), RIG)


def test_tolerance_zero_holds_a_value_fixed_in_the_calibration(tmp_path: Path) -> None:
    text = (PROJECT / "bags" / "one_washer_lti.rig.yaml").read_text()
    rig_file = tmp_path / "rig.yaml"
    rig_file.write_text(text + "  tolerances: {caliper.stiffness: 0, seal.shear_length: 0.0}\n")
    names = {u.name for u in uncertain_values(load_rig(rig_file))}
    assert "caliper_stiffness" not in names and "effective_hydraulic_stiffness" not in names
    assert "valve_resistance" in names


def test_an_analysis_error_is_named_after_the_recording_and_numbers_become_one() -> None:
    path = Path("run.mcap")
    with pytest.raises(SignalError, match=r"^run.mcap: no steady segment$"):
        with naming(path):
            raise SignalError("no steady segment")
    with pytest.raises(SignalError, match=r"^run.mcap: the analysis failed .*ZeroDivisionError"):
        with naming(path):
            _ = 1.0 / 0.0
