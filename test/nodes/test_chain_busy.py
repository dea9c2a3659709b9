"""The chain on a busy machine: it scores the recording's steady cycles, or says why it did not.

``python -m brake_hil.nodes.chain`` on ``bags/one_washer_open`` with its rig file, every process
pinned (``taskset -c 0``) to one core beside a busy process pinned there too: half a core for
four nodes at 1 kHz, as on a loaded runner or rig PC. Either the run scores at least 90 % of
the steady cycles the recording holds on every channel and exits 0, or it exits 1 with a line
naming the cause; never exit 0 with the cycles short. The expected count comes from the
recording, offline (``expected_cycles``), not from the run.
"""

from __future__ import annotations

import json
from pathlib import Path
import shutil
import subprocess
import sys

import numpy as np
import pytest

from brake_hil.analysis.stamp_scoring import expected_cycles
from brake_hil.app.chain import ros_environment
from brake_hil.io.recording_reader import read_recording
from test.conftest import PROJECT

RECORDING = PROJECT / "bags" / "one_washer_open"
RIG = PROJECT / "bags" / "one_washer_open.rig.yaml"
CAUSES = (
    "too few steady cycles scored",
    "not a real-time run",
    "loop timing ERROR",
    "samples were lost",
    "the run was cut short",
    "nodes exited with errors",
    "cannot tell",
)
"""How the closing lines of a failed run begin (``chain_result``'s judgements)."""


def _expected() -> dict[str, int]:
    recording = read_recording(RECORDING)
    stamps = np.round(recording.time * 1e9).astype(np.int64)
    measured = {c: v for c, v in recording.measured().items() if v is not None}
    return expected_cycles(stamps, measured)


@pytest.mark.skipif(shutil.which("taskset") is None, reason="needs taskset (util-linux)")
def test_the_chain_on_one_shared_core_scores_the_cycles_or_says_why_not(tmp_path: Path) -> None:
    busy = subprocess.Popen(["taskset", "-c", "0", sys.executable, "-c", "while 1: pass"])
    try:
        done = subprocess.run(
            ["taskset", "-c", "0", sys.executable, "-m", "brake_hil.nodes.chain"]
            + [str(RECORDING), "--model", str(RIG), "--out", str(tmp_path)],
            env=ros_environment(),
            capture_output=True,
            text=True,
            timeout=600,
            check=False,
        )
    finally:
        busy.kill()
        busy.wait()
    output = done.stdout + done.stderr
    summary = json.loads((tmp_path / "comparator.json").read_text(encoding="utf-8"))
    scored = {channel: entry["cycles"] for channel, entry in summary["metrics"].items()}
    expected = _expected()
    assert all(expected.values()), expected  # the recording holds steady cycles to score
    short = [c for c, n in expected.items() if scored[c] < 0.9 * n]
    if done.returncode == 0:
        assert not short, f"exit 0 with the cycles short: {scored} of {expected}\n{output}"
        line = "chain: steady cycles scored: " + ", ".join(
            f"{c} {scored[c]} of {n}" for c, n in expected.items()
        )
        assert line in done.stdout, output
    else:
        assert done.returncode == 1, output
        causes = [
            line
            for line in done.stderr.splitlines()
            if line.startswith("chain: ") and line[len("chain: ") :].startswith(CAUSES)
        ]
        assert causes, output
        if short:
            assert any("too few steady cycles scored" in line for line in causes), output
    assert "Traceback" not in output
