"""The rig emulator's CAN frames, across processes: the emulator node (its own process) sends
the DBC's frames on an slcan pseudo-terminal; a CanDaq in this process decodes them.

Needs pyserial (python-can's slcan interface opens the pty through it).
"""

from __future__ import annotations

import os
from pathlib import Path
import subprocess
import sys
import time

import numpy as np
import pytest

from brake_hil.app.chain import ros_environment
from brake_hil.io.can_daq import CanDaq, DaqStatus, DecodedSample
from brake_hil.nodes import common
from brake_hil.nodes.rig_emulator import precompute_run
from brake_hil.physics.excitation import PulsingSchedule
from brake_hil.physics.rig import load_rig

pytest.importorskip("serial", reason="python-can's slcan interface needs pyserial")

RUN = {"simulator": "lti", "ramp_s": 0.5, "pulsing_s": 1.5, "seed": 3}


def test_emulator_frames_over_slcan_decode_to_the_run_it_plays(tmp_path: Path) -> None:
    link = tmp_path / "rig_can"
    command = [sys.executable, "-m", "brake_hil.nodes.rig_emulator", "--ros-args"]
    parameters = {
        **RUN,
        "output": "can",
        "can_link_path": str(link),
        "loop": False,
        "start_delay_s": 3.0,  # the DAQ here opens the pty first, even on a busy machine
    }
    for name, value in parameters.items():
        command += ["-p", f"{name}:={value}"]
    domain = 101 + (os.getpid() * 7919 + time.time_ns() // 1_000_000) % 100
    log = (tmp_path / "emulator.log").open("wb")
    emulator = subprocess.Popen(command, env=ros_environment(domain), stdout=log, stderr=log)
    got: list[DecodedSample] = []
    try:
        # The adapter appears when the emulator has started: CanDaq retries until then.
        with CanDaq(
            "slcan",
            str(link),
            1_000_000,
            bus_kwargs={"sleep_after_open": 0},
            reconnect_max_s=0.2,
        ) as daq:
            deadline = time.monotonic() + 30.0
            while emulator.poll() is None and time.monotonic() < deadline:
                got += daq.poll(timeout=0.01)
            got += daq.poll(timeout=0.05)
            health = daq.health()
        assert emulator.wait(10) == 0, (tmp_path / "emulator.log").read_text()
    finally:
        if emulator.poll() is None:
            emulator.kill()
            emulator.wait(10)
        log.close()

    run = precompute_run(
        load_rig(common.config_path("rig_default.yaml")),
        RUN["simulator"],
        schedule=PulsingSchedule(ramp_s=RUN["ramp_s"], pulsing_s=RUN["pulsing_s"]),
        seed=RUN["seed"],
    )
    hydraulic = [s for s in got if s.frame == "BRAKE_HYDRAULIC"]
    assert len(hydraulic) > 0.8 * run.samples  # all but what was sent before the DAQ opened
    for sample in got:
        for quantity, value in sample.values.items():
            assert value == run.measured[quantity][sample.counter]  # bit-exact
    counters = [s.counter for s in hydraulic]
    assert counters == list(range(counters[0], counters[0] + len(counters)))
    assert health.crc_errors == health.dlc_errors == health.unknown_ids == 0
    assert health.lost_samples == 0
    assert health.status is DaqStatus.ADAPTER_LOST  # the emulator has gone, the pty with it
    steps = np.diff([s.stamp_ns for s in hydraulic])
    assert np.median(steps) == 1_000_000  # acquisition stamps on the 1 kHz grid
    assert np.all(np.abs(steps[len(steps) // 2 :] - 1_000_000) < 500_000)


def test_the_default_pty_link_is_in_a_private_temp_folder(tmp_path: Path) -> None:
    import re
    import signal
    import stat
    import tempfile

    fixed = Path(tempfile.gettempdir()) / "brake_hil_rig_can"
    existed = fixed.exists() or fixed.is_symlink()
    command = [sys.executable, "-m", "brake_hil.nodes.rig_emulator", "--ros-args"]
    for name, value in {**RUN, "output": "can", "wait_timeout_s": 60.0}.items():
        command += ["-p", f"{name}:={value}"]
    log_path = tmp_path / "emulator.log"
    with log_path.open("wb") as log:
        emulator = subprocess.Popen(command, env=ros_environment(), stdout=log, stderr=log)
    try:
        deadline = time.monotonic() + 60.0
        found = None
        while found is None and time.monotonic() < deadline and emulator.poll() is None:
            found = re.search(r"\(link (\S+)\)", log_path.read_text(errors="replace"))
            time.sleep(0.1)
        assert found, log_path.read_text()
        link = Path(found.group(1))
        folder = link.parent
        assert folder.parent == Path(tempfile.gettempdir())
        assert folder.name.startswith("brake_hil_rig_can_") and link.name == "rig_can"
        mode = folder.lstat()
        assert stat.S_ISDIR(mode.st_mode) and not stat.S_ISLNK(mode.st_mode)
        assert stat.S_IMODE(mode.st_mode) == 0o700 and mode.st_uid == os.getuid()
        assert os.readlink(link).startswith("/dev/pts/")
    finally:
        emulator.send_signal(signal.SIGINT)
        code = emulator.wait(30)
    assert code == 0, log_path.read_text()
    assert not folder.exists()  # removed at exit
    assert (fixed.exists() or fixed.is_symlink()) == existed  # the fixed name is not touched
