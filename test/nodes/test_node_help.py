"""Every node and the chain launcher answer -h/--help, exit 0, start nothing, write nothing."""

from __future__ import annotations

import os
from pathlib import Path
import subprocess
import sys

import pytest
import rclpy

from brake_hil.nodes import common
from brake_hil.nodes.recorder import main as recorder_main
from brake_hil.nodes.settings import NODE_SETTINGS, help_text, parameter_specs

PROJECT = Path(__file__).resolve().parents[2]


def _run(module: str, flag: str, cwd: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(PROJECT), HOME=str(cwd))
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    return subprocess.run(
        [sys.executable, "-m", module, flag, *extra],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


@pytest.mark.parametrize("flag", ["--help", "-h"])
@pytest.mark.parametrize("node", sorted(NODE_SETTINGS))
def test_node_help_lists_every_parameter_and_writes_nothing(
    node: str, flag: str, tmp_path: Path
) -> None:
    done = _run(f"brake_hil.nodes.{node}", flag, tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"usage: {node}")
    for spec in parameter_specs(NODE_SETTINGS[node]):
        assert f"  {spec.name}  " in done.stdout
        assert spec.description in done.stdout
        if spec.unit:
            assert f"[{spec.unit}]" in done.stdout
    assert list(tmp_path.iterdir()) == []  # no bag, no log, no file of any kind
    assert done.stderr == ""  # no ROS logging: rclpy never started


def test_recorder_help_with_ros_arguments_makes_no_bag(tmp_path: Path) -> None:
    out = tmp_path / "bags"
    done = _run("brake_hil.nodes.recorder", "--help", tmp_path, "--ros-args", "-p",
                f"output_dir:={out}")  # fmt: skip
    assert done.returncode == 0
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_help_in_process_leaves_rclpy_unstarted(capsys: pytest.CaptureFixture[str]) -> None:
    assert recorder_main(["recorder", "--help"]) == 0
    assert not rclpy.ok()
    assert capsys.readouterr().out == help_text("recorder") + "\n"


def test_help_flag_after_ros_args_is_not_the_nodes() -> None:
    assert common.asks_for_help(["-h"])
    assert common.asks_for_help(["node", "--help", "--ros-args", "-p", "a:=1"])
    assert not common.asks_for_help(["--ros-args", "-p", "a:=1", "-h"])
    assert not common.asks_for_help([])


@pytest.mark.parametrize("flag", ["--help", "-h"])
def test_chain_help_exits_0_and_starts_nothing(flag: str, tmp_path: Path) -> None:
    done = _run("brake_hil.nodes.chain", flag, tmp_path)
    assert done.returncode == 0, done.stderr
    assert "usage: python -m brake_hil.nodes.chain" in done.stdout
    assert "--realtime-priority" in done.stdout
    assert list(tmp_path.iterdir()) == []


def test_recorder_default_directory_is_never_the_source_tree(tmp_path: Path) -> None:
    home = Path("~/brake_hil_recordings").expanduser()
    assert common.recording_directory("", cwd=tmp_path) == tmp_path
    assert common.recording_directory("", cwd=PROJECT) == home
    assert common.recording_directory("", cwd=PROJECT / "bags") == home
    assert common.recording_directory(str(tmp_path / "x")) == tmp_path / "x"
