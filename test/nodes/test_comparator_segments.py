"""The live comparator scores a ramp per segment (real nodes, real DDS).

``python -m brake_hil.nodes.chain`` replays ``bags/ramp_one_washer`` (8 s, no steady
pulsing) through its own rig file: the comparator scores no steady cycle, but at the end it
scores every segment of what it received as ``regress`` scores the recording, prints them,
and writes them to its summary; the launcher says what it scored.
"""

from __future__ import annotations

import json
from pathlib import Path
import subprocess
import sys

import pytest

from brake_hil.app.chain import ros_environment
from brake_hil.app.regress import replay_recording
from brake_hil.io.recording_reader import read_recording
from test.conftest import PROJECT

RAMP = PROJECT / "bags" / "ramp_one_washer"
MODEL = PROJECT / "bags" / "ramp_one_washer.rig.yaml"
LATE = ("chain: not a real-time run", "chain: loop timing ERROR")
"""Closing lines of a run that did not keep real time (a busy runner): not what is tested."""


def test_a_replayed_ramp_is_scored_per_segment_by_the_live_comparator(tmp_path: Path) -> None:
    command = [sys.executable, "-m", "brake_hil.nodes.chain", str(RAMP), "--model", str(MODEL)]
    command += ["--out", str(tmp_path), "--no-recorder"]
    done = subprocess.run(
        command, env=ros_environment(), capture_output=True, text=True, timeout=300
    )
    failed = [line for line in done.stderr.splitlines() if line.startswith("chain: ")]
    assert done.returncode == 0 or all(line.startswith(LATE) for line in failed), done.stderr
    assert "chain: no steady 5 Hz cycle; 3 segments scored each (ramp, hold)" in done.stdout
    assert "segments of the run" in done.stdout
    summary = json.loads((tmp_path / "comparator.json").read_text())
    live = [s for s in summary["segments"]["segments"] if s.get("metrics")]
    offline = [
        s for s in replay_recording(read_recording(RAMP), MODEL).scored_segments if s["metrics"]
    ]
    assert [s["kind"] for s in live] == [s["kind"] for s in offline] == ["ramp", "hold", "ramp"]
    for ours, theirs in zip(live, offline):
        for channel in ("p_b", "F_k", "x_c"):
            for key in ("map_gain_ratio_pct", "level_error_pct", "loop_width_error_pct"):
                if key in theirs["metrics"][channel]:
                    assert ours["metrics"][channel][key] == pytest.approx(
                        theirs["metrics"][channel][key], abs=0.05
                    ), (channel, key)
    assert summary["segments"]["interpolated_share"] < 0.01
