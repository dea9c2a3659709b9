"""Every command block of the README works as written on a clean checkout.

The fast blocks run always; the long ones (those holding a marker of ``LONG``: the main job,
the CAN chain, the benchmarks) only with ``BRAKE_HIL_README_LONG=1``. Each block runs in a
subprocess, so these tests are marked ``slow`` (``test/conftest.py``). ``bash
scripts/test.sh`` is this test suite itself and is never run from it. Without ``.venv/`` in
the checkout (a developer's worktree), ``.venv/bin/`` stands for this interpreter's ``python``
and ``brake-hil``, and ``bash scripts/run_chain.sh`` for the launcher it ``exec``s after its
set-up step.
"""

from __future__ import annotations

import os
from pathlib import Path
import re
import shlex
import subprocess
import sys

import pytest

from test.conftest import PROJECT

README = PROJECT / "README.md"
BENCHMARKS = PROJECT / "docs" / "benchmarks.md"
LONG = (
    "scripts/main.sh",
    "--can-emulator",
    "benchmarks/",
    "brake-hil cases",
    "benchmark ",
    "brake-hil fleet",
    "brake-hil trend",
    "dask ",
    "out/lab",  # the virtual lab's walk-through: its recordings come from 'brake-hil fleet'
    "write_dask_config",  # writes into the user's Dask config folder
)
NEVER = ("scripts/test.sh",)
CHAIN_TIMING_CAUSES = ("chain: not a real-time run", "chain: loop timing ERROR", "chain: too few")
"""A chain that lost nothing but could not keep real time on a busy runner says so, exit 1."""


def readme_commands() -> list[str]:
    """The command lines of the README's ``bash`` blocks, comments dropped."""
    blocks = re.findall(r"```bash\n(.*?)```", README.read_text(), flags=re.DOTALL)
    lines = [line.split(" #")[0].strip() for block in blocks for line in block.splitlines()]
    return [line for line in lines if line and not line.startswith("#")]


def _is_long(command: str) -> bool:
    """Whether a README command is a long one (it holds a marker of ``LONG``)."""
    return any(marker in command for marker in LONG)


def _shim(folder: Path) -> Path:
    """``python`` and ``brake-hil`` of this interpreter, for a checkout without ``.venv/``."""
    folder.mkdir(parents=True, exist_ok=True)
    scripts = {
        "python": f'exec {shlex.quote(sys.executable)} "$@"\n',
        "brake-hil": f'exec {shlex.quote(sys.executable)} -m brake_hil.cli "$@"\n',
    }
    for name, body in scripts.items():
        path = folder / name
        path.write_text("#!/usr/bin/env bash\n" + body)
        path.chmod(0o755)
    return folder


def _as_run_here(command: str, shim: Path) -> str:
    if (PROJECT / ".venv" / "bin" / "python").exists():
        return command
    command = command.replace(
        "bash scripts/run_chain.sh", ".venv/bin/python -m brake_hil.nodes.chain"
    )
    return command.replace(".venv/bin/", f"{shim}/")


def test_the_readme_has_fast_command_blocks() -> None:
    commands = readme_commands()
    fast = [c for c in commands if not _is_long(c) and not any(n in c for n in NEVER)]
    assert any("regress bags/" in c for c in fast)
    assert any("run_chain.sh" in c for c in fast)
    assert any("main.sh" in c for c in commands)


@pytest.mark.parametrize("command", readme_commands())
def test_readme_command_works_as_written(command: str, tmp_path: Path) -> None:
    if any(marker in command for marker in NEVER):
        pytest.skip("the test suite itself")
    if _is_long(command) and os.environ.get("BRAKE_HIL_README_LONG") != "1":
        pytest.skip("long: set BRAKE_HIL_README_LONG=1")
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    env["PYTHONPATH"] = str(PROJECT)
    done = subprocess.run(
        ["bash", "-c", "set -euo pipefail; " + _as_run_here(command, _shim(tmp_path / "bin"))],
        cwd=PROJECT,
        env=env,
        capture_output=True,
        text=True,
        timeout=1800,
        check=False,
    )
    failed = [line for line in done.stderr.splitlines() if line.startswith("chain: ")]
    late = bool(failed) and all(line.startswith(CHAIN_TIMING_CAUSES) for line in failed)
    held = done.returncode == 0 or ("run_chain.sh" in command and done.returncode == 1 and late)
    assert held, f"{command}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    if "regress" in command:
        assert "every metric within its tolerance" in done.stdout
        assert "ramp_one_washer: 8001 samples" in done.stdout  # scored per segment
    if "run_chain.sh" in command:
        assert "MCAP recording:" in done.stdout


def _benchmark_scripts() -> list[str]:
    """The benchmark scripts the README's and docs/benchmarks.md's commands run."""
    text = README.read_text() + BENCHMARKS.read_text()
    found = re.findall(r"benchmarks/bench_\w+\.py", text)
    return sorted(set(found))


def test_the_readme_names_benchmark_scripts_that_exist() -> None:
    scripts = _benchmark_scripts()
    assert len(scripts) >= 5
    for script in scripts:
        assert (PROJECT / script).is_file(), script


@pytest.mark.parametrize("script", _benchmark_scripts())
def test_each_benchmark_the_readme_names_starts_as_written(script: str) -> None:
    # The long runs are skipped above; each script must at least start from the checkout as
    # the README runs it (python benchmarks/X.py: imports, the project on its path, options).
    done = subprocess.run(
        [sys.executable, script, "--help"],
        cwd=PROJECT,
        env=dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, f"{script}\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
    assert "usage:" in done.stdout
