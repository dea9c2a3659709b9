"""The pressure source replaying a lab's CAN log, across processes, over DDS.

A BLF log written by python-can's ``BLFWriter`` from frames encoded with the DBC is replayed by
the source node (its own process, ``mode: can_log``); a collector node here receives every
sample once with its decoded value, stamped one sample period apart, and the node exits at the
log's end with the counts in its statistics file. A truncated log is one line and exit 2.
"""

from __future__ import annotations

import json
from pathlib import Path
import subprocess
import sys

from brake_hil.app.chain import ros_environment, start_node, stop_node
from brake_hil.nodes import common
from brake_hil.topics import BLOCK_FORCE, BORE_PRESSURE, CALIPER_DISPLACEMENT
from brake_hil.topics import MASTER_CYLINDER_PRESSURE as P_I
from test.io.test_can_log import pressures, write_log
from test.nodes.harness import Collector, ros_domain, unique_domain_id
from test.waiting import wait_until

TOPICS = (P_I, BORE_PRESSURE, BLOCK_FORCE, CALIPER_DISPLACEMENT)
SAMPLES = 1500  # 1.5 s of log at 1 kHz


def test_the_source_publishes_a_can_logs_samples(tmp_path: Path) -> None:
    log = tmp_path / "lab.blf"
    codec = write_log(log, range(SAMPLES))
    statistics = tmp_path / "statistics.json"
    parameters = {
        "mode": "can_log",
        "can_log": str(log),
        "rate": 1.0,
        "wait_for_subscribers": 1,
        "wait_timeout": 60.0,
        "exit_at_end": True,
        "statistics_file": str(statistics),
    }
    with ros_domain(unique_domain_id()) as env:
        collector = Collector(TOPICS, [common.DIAGNOSTICS_TOPIC])
        source = start_node("pressure_source", parameters, env, tmp_path)
        try:
            ended = wait_until(lambda: source.process.poll() is not None, 120.0)
            wait_until(lambda: len(collector.samples[P_I.name]) >= SAMPLES, 10.0)
        finally:
            exit_code = stop_node(source, timeout_s=10.0)
            collector.close()
    node_log = (tmp_path / "pressure_source.log").read_text()
    assert ended and exit_code == 0, node_log
    samples = collector.samples[P_I.name]
    assert len(samples) == SAMPLES, node_log
    frames = [codec.encode(i, pressures(i))[0] for i in range(SAMPLES)]
    expected = [codec.decode(frame).values["p_i"] for frame in frames]
    assert [value for _, value, _ in samples] == expected  # the DBC's decoding, bit-exact, once
    stamps = [stamp for stamp, _, _ in samples]
    assert all(abs(b - a - 1_000_000) <= 2_000 for a, b in zip(stamps, stamps[1:])), stamps[:5]
    for spec in TOPICS[1:]:
        assert len(collector.samples[spec.name]) == SAMPLES, spec.name
    summary = json.loads(statistics.read_text())
    assert summary["mode"] == "can_log" and summary["published"] == SAMPLES
    assert summary["can_log"]["frames"] == 2 * SAMPLES
    assert summary["can_log"]["frames_ok"] == 2 * SAMPLES
    assert summary["can_log"]["lost_samples"] == 0
    assert "CAN log finished" in node_log


def test_a_truncated_log_is_one_line_and_exit_2(tmp_path: Path) -> None:
    log = tmp_path / "lab.blf"
    write_log(log, range(300))
    log.write_bytes(log.read_bytes()[:-100])
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "brake_hil.nodes.pressure_source",
            "--ros-args",
            "-p",
            "mode:=can_log",
            "-p",
            f"can_log:={log}",
        ],
        env=ros_environment(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2, result.stdout + result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and f"{log}: truncated" in lines[0], result.stderr
