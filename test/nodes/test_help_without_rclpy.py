"""Every console script, the container and the chain launcher answer --help without rclpy.

Each runs in a subprocess where ``import rclpy`` fails: the help is parsed and printed before
any ROS import. The help is plain text: no Sphinx roles, no default said twice.
"""

from __future__ import annotations

from importlib.metadata import entry_points
import os
from pathlib import Path
import re
import subprocess
import sys

import pytest

PROJECT = Path(__file__).resolve().parents[2]
NO_RCLPY = "import sys; sys.modules['rclpy'] = None\n"
"""Makes ``import rclpy`` raise ImportError in the subprocess."""


def _console_scripts() -> dict[str, str]:
    """The package's console scripts: name -> ``module:function``."""
    scripts = {
        ep.name: ep.value
        for ep in entry_points(group="console_scripts")
        if ep.value.startswith("brake_hil.")
    }
    if not scripts:
        pytest.skip("brake_hil is not installed (no console scripts)")
    return scripts


NODES = ("caliper_model", "chain", "comparator", "container", "pressure_source", "recorder")
COMMANDS = {name: f"brake_hil.nodes.{name}:main" for name in (*NODES, "rig_emulator")}
"""The entry points checked besides the installed console scripts (the ``python -m`` ones)."""


def _help(target: str, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    module, _, function = target.partition(":")
    code = (
        NO_RCLPY
        + f"sys.argv = [{module!r}, '--help']\n"
        + f"from {module} import {function} as entry\n"
        + "status = entry()\n"
        + "sys.exit(status if isinstance(status, int) else 0)\n"
    )
    env = dict(os.environ, PYTHONPATH=str(PROJECT), HOME=str(tmp_path))
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    return subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def _check_plain(text: str) -> None:
    flat = " ".join(text.split())
    for role in (":mod:", ":class:", ":func:", ":data:", ":attr:", "~brake_hil"):
        assert role not in flat
    assert not re.search(r"\(default: [^)]*\) \(default: None\)", flat), flat


def test_console_scripts_answer_help_without_rclpy(tmp_path: Path) -> None:
    for name, target in sorted(_console_scripts().items()):
        done = _help(target, tmp_path)
        assert done.returncode == 0, f"{name}: {done.stderr}"
        assert "usage:" in done.stdout, name
        _check_plain(done.stdout)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_node_entry_points_answer_help_without_rclpy(name: str, tmp_path: Path) -> None:
    done = _help(COMMANDS[name], tmp_path)
    assert done.returncode == 0, done.stderr
    assert "usage:" in done.stdout
    assert "ModuleNotFoundError" not in done.stderr
    _check_plain(done.stdout)
    assert list(tmp_path.iterdir()) == []
