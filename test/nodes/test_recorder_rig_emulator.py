"""The whole chain without hardware: the rig emulator plays a run on the contract topics, the
recorder records it, and the recording reads back as the run that was played (both nodes as
their own processes, on a ROS domain of their own)."""

from __future__ import annotations

import os
from pathlib import Path
import signal
import subprocess
import sys
import time

import numpy as np

from brake_hil.app.chain import ros_environment
from brake_hil.io.recording_reader import read_recording
from brake_hil.topics import MEASURED_OUTPUTS
from test.nodes.harness import emulated_run

RUN = {"simulator": "lti", "ramp_s": 0.5, "pulsing_s": 1.0, "seed": 7}


def node_command(name: str, parameters: dict[str, object]) -> list[str]:
    command = [sys.executable, "-m", f"brake_hil.nodes.{name}", "--ros-args"]
    for key, value in parameters.items():
        command += ["-p", f"{key}:={value}"]
    return command


def test_recording_of_the_emulated_rig_is_the_run_it_played(tmp_path: Path) -> None:
    env = ros_environment(101 + (os.getpid() * 7919 + time.time_ns() // 1_000_000) % 100)
    log = (tmp_path / "nodes.log").open("wb")
    recorder = subprocess.Popen(
        node_command("recorder", {"output_dir": str(tmp_path), "bag_name": "bag"}),
        env=env,
        stdout=log,
        stderr=log,
    )
    emulator_parameters = {
        **RUN,
        "output": "topics",
        "loop": False,
        "wait_for_subscribers": 1,
        "start_delay_s": 0.5,
    }
    emulator = subprocess.Popen(
        node_command("rig_emulator", emulator_parameters), env=env, stdout=log, stderr=log
    )
    try:
        assert emulator.wait(30) == 0
        time.sleep(0.3)
        recorder.send_signal(signal.SIGTERM)
        assert recorder.wait(20) == 0
    finally:
        for process in (emulator, recorder):
            if process.poll() is None:
                process.kill()
                process.wait(10)
        log.close()

    run = emulated_run(RUN)
    recording = read_recording(tmp_path / "bag", required=MEASURED_OUTPUTS)
    assert recording.time.size == run.samples, (tmp_path / "nodes.log").read_text()
    steps_ns = np.round(np.diff(recording.time) * 1e9)
    assert np.all(steps_ns == 1_000_000)  # stamps = acquisition times, 1 kHz
    np.testing.assert_array_equal(recording.master_cylinder_pressure, run.measured["p_i"])
    np.testing.assert_array_equal(recording.bore_pressure, run.measured["p_b"])
    np.testing.assert_array_equal(recording.block_force, run.measured["F_k"])
    np.testing.assert_array_equal(recording.caliper_displacement, run.measured["x_c"])
