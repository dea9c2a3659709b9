"""The chain launcher says when samples were lost, and exits non-zero (real nodes, real DDS).

``python -m brake_hil.nodes.chain`` on ``bags/one_washer_lti`` (18 s, real time), twice:
as it is (every sample predicted and recorded: exit 0 and one line saying so); with the
recorder stopped (SIGSTOP) for 8 s in the middle, as a busy runner can starve it (the sample
topics' 30 s of history hold what comes meanwhile: it catches up, nothing is lost); and with
the recorder killed (SIGKILL) in the middle: samples are lost, the launcher prints one line
saying how many and exits 1. The count is checked against the MCAP the recorder left, read
with ``mcap`` (not our reader).
"""

from __future__ import annotations

import os
from pathlib import Path
import re
import signal
import subprocess
import sys
import time

import pytest

from brake_hil.app.chain import ros_environment
from test.conftest import PROJECT

RECORDING = PROJECT / "bags" / "one_washer_lti"
SAMPLES = 18_000


TIMING_CAUSES = ("chain: not a real-time run", "chain: loop timing ERROR", "chain: too few steady")
"""Closing lines of a run that lost nothing but did not keep real time (a busy runner)."""


def _held_or_only_late(returncode: int, stderr: str) -> bool:
    """Exit 0, or 1 with nothing but timing causes on stderr: the samples' verdict held."""
    failed = [line for line in stderr.splitlines() if line.startswith("chain: ")]
    late = bool(failed) and all(line.startswith(TIMING_CAUSES) for line in failed)
    return returncode == 0 or (returncode == 1 and late)


def _launch(out: Path) -> subprocess.Popen[str]:
    command = [
        sys.executable,
        "-m",
        "brake_hil.nodes.chain",
        str(RECORDING),
        "--out",
        str(out),
        *("--layout", "processes"),  # the recorder in a process of its own, to stop or kill
    ]
    return subprocess.Popen(
        command, env=ros_environment(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def _recorder_pid(out: Path, timeout_s: float = 60.0) -> int | None:
    """The pid of this run's recorder: its command line names this run's params file."""
    params = str(out / "logs" / "recorder.params.yaml")
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        for entry in Path("/proc").iterdir():
            if not entry.name.isdigit():
                continue
            try:
                arguments = (entry / "cmdline").read_bytes().split(b"\0")
            except OSError:
                continue
            if b"brake_hil.nodes.recorder" in arguments and params.encode() in arguments:
                return int(entry.name)
        time.sleep(0.1)
    return None


def _recorded_inputs(out: Path) -> int:
    from mcap.reader import make_reader

    count = 0
    for path in sorted(out.glob("chain_*/*.mcap")):
        with path.open("rb") as stream:
            for _, channel, _ in make_reader(stream).iter_messages():
                count += channel.topic == "/brake/master_cylinder/pressure"
    return count


def test_a_complete_run_says_so_and_exits_0(tmp_path: Path) -> None:
    launcher = _launch(tmp_path)
    stdout, stderr = launcher.communicate(timeout=300)
    assert _held_or_only_late(launcher.returncode, stderr), stdout + stderr
    line = f"chain: every sample predicted and recorded: {SAMPLES} samples published, {SAMPLES}"
    assert line in stdout, stdout


def _signal_recorder_mid_run(out: Path, signum: int) -> int:
    """Send ``signum`` to this run's recorder 2 s into the replay; its pid."""
    pid = _recorder_pid(out)
    assert pid is not None, "the recorder did not start"
    log = out / "logs" / "pressure_source.log"
    deadline = time.monotonic() + 120.0
    while time.monotonic() < deadline and "replaying" not in (
        log.read_text(errors="replace") if log.exists() else ""
    ):
        time.sleep(0.1)
    time.sleep(2.0)  # the replay is under way
    os.kill(pid, signum)
    return pid


def test_a_recorder_starved_for_8_s_catches_up_and_the_run_is_complete(tmp_path: Path) -> None:
    launcher = _launch(tmp_path)
    pid = _signal_recorder_mid_run(tmp_path, signal.SIGSTOP)
    try:
        time.sleep(8.0)  # longer than the 5 s of history the sample topics had
    finally:
        os.kill(pid, signal.SIGCONT)
    stdout, stderr = launcher.communicate(timeout=300)
    assert _held_or_only_late(launcher.returncode, stderr), stdout + stderr
    line = f"chain: every sample predicted and recorded: {SAMPLES} samples published, {SAMPLES}"
    assert line in stdout, stdout
    assert _recorded_inputs(tmp_path) == SAMPLES


def test_samples_lost_by_the_recorder_make_the_chain_fail_with_one_line(tmp_path: Path) -> None:
    launcher = _launch(tmp_path)
    _signal_recorder_mid_run(tmp_path, signal.SIGKILL)
    stdout, stderr = launcher.communicate(timeout=300)
    assert launcher.returncode == 1, stdout + stderr
    lines = [line for line in stderr.splitlines() if line.startswith("chain: samples were lost")]
    assert len(lines) == 1, stderr
    found = re.search(
        r"(\d+) samples published.*?(\d+) inputs and \d+ predictions recorded "
        r"\((\d+) lost\)",
        lines[0],
    )
    assert found, lines[0]
    published, inputs, lost = (int(group) for group in found.groups())
    assert published == SAMPLES and lost > 0
    assert inputs == _recorded_inputs(tmp_path) < SAMPLES


if not hasattr(signal, "SIGSTOP"):  # pragma: no cover - POSIX only
    pytestmark = pytest.mark.skip(reason="needs SIGSTOP")
