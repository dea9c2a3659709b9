"""The rig emulator's CAN frames, across processes: the emulator node (its own process) sends
the DBC's frames on an slcan pseudo-terminal; a CanDaq in this process decodes them.

Needs pyserial (python-can's slcan interface opens the pty through it).
"""

from __future__ import annotations

import os
from pathlib import Path
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from brake_hil.app.chain import ros_environment
from brake_hil.io.can_daq import CanDaq, DaqStatus, DecodedSample
from brake_hil.nodes.rig_emulator_node import _CanOutput
from test.nodes.harness import emulated_run

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
        # the DAQ here opens the pty first, even on a busy runner (at load 8-10 it had not
        # within 3 s, and read 1 frame of 2000)
        "start_delay_s": 15.0,
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
            deadline = time.monotonic() + 60.0
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

    run = emulated_run(RUN)
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


def test_a_stalled_can_reader_gets_every_frame_late_and_loses_none(tmp_path: Path) -> None:
    """A reader starved on a busy machine got 2225 of a chain's 3000 samples: the emulator
    dropped every frame that found the pty full. Holding a frame (``can_hold_s``) until the
    reader reads again delivers every one, late; without the hold the same stall loses the
    frames that found the pty full (the second case, which also shows the stall filled it)."""
    run = emulated_run(RUN, pulsing_s=0.5)  # 1000 samples, 44 KB of slcan
    rows = [{key: float(v[k]) for key, v in run.measured.items()} for k in range(run.samples)]
    results = []
    for hold_s in (30.0, 0.0):
        output = _CanOutput(
            "slcan_pty", "", 1_000_000, str(tmp_path / f"can_{hold_s:g}"), "", hold_s
        )
        total = run.samples * len(output.codec.encode(0, rows[0]))
        try:
            with CanDaq(
                "slcan", str(output.pty.link_path), 1_000_000, bus_kwargs={"sleep_after_open": 0}
            ) as daq:
                assert poll_until_open(output, daq)
                sender = threading.Thread(target=play, args=(output, rows))
                sender.start()
                stall_until_the_pty_is_full(output, sender)  # the reader is starved
                got = read_until_quiet(daq, total, sender)
                sender.join(60.0)
                health = daq.health()
        finally:
            output.close()
        results.append((len(got), output.sent, output.dropped, health.lost_samples))
    held, free = results
    assert held == (total, total, 0, 0)
    assert free[1] + free[2] == total and free[2] > 0 and free[0] < total


def test_a_gone_can_reader_costs_one_hold_not_one_per_frame(tmp_path: Path) -> None:
    """Nobody reads the pty: the first frame that finds it full is held ``can_hold_s`` in vain
    and dropped; the rest are dropped at once (the playback keeps its pace), until a frame fits
    again (a reader has read): then frames are held again."""
    output = _CanOutput("slcan_pty", "", 1_000_000, str(tmp_path / "rig_can"), "", 0.2)
    values = {"p_i": 1.0e6, "p_b": 1.0e6, "F_k": 1.0e3, "x_c": -1.0e-5}
    in_vain: list[float] = []
    send = output.pty.send

    def watched(frames: list, wait_s: float = 0.0) -> int:
        written = int(send(frames, wait_s))
        if not written:
            in_vain.append(wait_s)
        return written

    output.pty.send = watched
    try:
        for k in range(1000):  # 2000 frames; the pty holds about 900
            output.send(k, values, 0.0)
        assert output.sent + output.dropped == 2000 and output.dropped > 1000
        assert in_vain == [0.2] + [0.0] * (output.dropped - 1)
        assert output.reader_stalled
        with CanDaq(
            "slcan", str(output.pty.link_path), 1_000_000, bus_kwargs={"sleep_after_open": 0}
        ) as daq:  # a reader comes: opening its adapter empties the pty
            assert poll_until_open(output, daq)
            output.send(1000, values, 0.0)
            assert [s.counter for s in read_until_quiet(daq, 2)] == [1000, 1000]
        assert not output.reader_stalled and output.sent + output.dropped == 2002
    finally:
        output.close()


def play(output: _CanOutput, rows: list[dict[str, float]]) -> None:
    """Send every sample at once, as a playback catching up does."""
    for k, row in enumerate(rows):
        output.send(k, row, 0.0)


def poll_until_open(output: _CanOutput, daq: CanDaq, timeout_s: float = 10.0) -> bool:
    """Answer the reader's commands until it has opened the channel (the DAQ opens its
    adapter when polled)."""
    deadline = time.monotonic() + timeout_s
    while not output.pty.poll_reader() and time.monotonic() < deadline:
        daq.poll(timeout=0.01)
    return bool(output.pty.reader_open)


def stall_until_the_pty_is_full(
    output: _CanOutput, sender: threading.Thread, timeout_s: float = 30.0
) -> None:
    """Read nothing until the sender drops a frame, has finished, or has sent nothing for
    0.5 s (it holds a frame: the pty is full)."""
    sent, since = -1, time.monotonic()
    deadline = since + timeout_s
    while sender.is_alive() and output.dropped == 0 and time.monotonic() < deadline:
        if output.sent != sent:
            sent, since = output.sent, time.monotonic()
        elif time.monotonic() - since > 0.5:
            return
        time.sleep(0.01)


def read_until_quiet(
    daq: CanDaq, frames: int, sender: threading.Thread | None = None
) -> list[DecodedSample]:
    """Frames until ``frames`` came, or the sender has finished and 0.5 s passed without one."""
    got: list[DecodedSample] = []
    quiet_since = time.monotonic()
    deadline = quiet_since + 60.0
    while len(got) < frames and time.monotonic() < deadline:
        new = daq.poll(timeout=0.01)
        got += new
        if new or (sender is not None and sender.is_alive()):
            quiet_since = time.monotonic()
        elif time.monotonic() - quiet_since > 0.5:
            break
    return got
