"""``brake-hil simulate`` on the virtual rig and ``brake-hil cases`` on the command line."""

from __future__ import annotations

import json
from pathlib import Path
import subprocess
import sys

from brake_hil.io.recording_reader import list_topics
from brake_hil.physics.rig import load_rig
from test.conftest import CONFIG

RIG = CONFIG / "rig_default.yaml"


def brake_hil(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "brake_hil.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=120,
    )


def _one_error_line(result: subprocess.CompletedProcess[str]) -> str:
    assert result.returncode == 2, (result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    return lines[0]


def test_simulate_on_the_virtual_rig_writes_the_bag_and_the_nominal_rig(tmp_path: Path) -> None:
    out = tmp_path / "sim"
    result = brake_hil(
        "simulate", "--rig", RIG, "--out", out, "--nominal", CONFIG / "rig_five_washers.yaml",
        "--effect", "orifice_flow=0.5", "--effect", "sensor_delay=0.3,channel=p_b",
        "--excitation", "solenoid", "--pulsing-seconds", "0.5", "--seed", "3",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "s simulated" in result.stderr  # the progress bar
    assert "orifice_flow=0.5, sensor_delay=0.3" in result.stdout
    topics = {topic.name: topic.message_count for topic in list_topics(out)}
    assert topics["/brake/air/pressure"] == topics["/brake/caliper/displacement"] == 1500
    assert load_rig(Path(f"{out}.rig.yaml")).washers == 5


def test_simulate_refuses_virtual_rig_options_with_the_lti_engine(tmp_path: Path) -> None:
    line = _one_error_line(
        brake_hil(
            "simulate",
            "--rig",
            RIG,
            "--out",
            tmp_path / "x",
            "--engine",
            "lti",
            "--effect",
            "orifice_flow",
        )  # fmt: skip
    )
    assert "--effect" in line and "virtual rig" in line


def test_simulate_names_an_unknown_effect(tmp_path: Path) -> None:
    line = _one_error_line(
        brake_hil("simulate", "--rig", RIG, "--out", tmp_path / "x", "--effect", "air=1")
    )
    assert "unknown effect 'air'" in line and "entrained_air" in line
    assert not (tmp_path / "x").exists()


def test_cases_writes_recordings_and_labels_apart(tmp_path: Path) -> None:
    out = tmp_path / "bench"
    result = brake_hil("cases", "--out", out, "--count", "1", "--pulsing-seconds", "0.4")
    assert result.returncode == 0, result.stderr
    assert (out / "cases" / "000" / "recording" / "metadata.yaml").is_file()
    assert json.loads((out / "labels.json").read_text())["cases"]["000"]["kind"] == "null"
    again = brake_hil("cases", "--out", out, "--count", "1")
    assert "not empty" in _one_error_line(again)


def test_cases_takes_another_excitation(tmp_path: Path) -> None:
    out = tmp_path / "bench"
    result = brake_hil(
        "cases", "--out", out, "--count", "1", "--excitation", "ramp", "--family", "c"
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    labels = json.loads((out / "labels.json").read_text())
    assert labels["generator"]["excitation"] == "ramp"
    assert labels["cases"]["000"]["excitation"].startswith("ramp to 2.76 MPa")
    topics = {
        topic.name: topic.message_count
        for topic in list_topics(out / "cases" / "000" / "recording")
    }
    assert topics["/brake/caliper/displacement"] == 8001
