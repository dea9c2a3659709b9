"""What a new user meets first on the command line: --version, help, quick start, defaults."""

from __future__ import annotations

import argparse
import io
import math
from pathlib import Path
import subprocess
import sys

import pytest

from brake_hil import __version__
from brake_hil.app import simulate as app_simulate
from brake_hil.app.recordings import recording_name, rig_beside
from brake_hil.cli import build_parser, parser
from brake_hil.cli.progress import progress_bar
from brake_hil.cli.verbs import benchmark
from brake_hil.errors import BrakeHilError
from brake_hil.virtual_rig import simulator
from brake_hil.virtual_rig.effects import EFFECTS


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, timeout=120, check=False
    )


def test_version() -> None:
    done = _run("-m", "brake_hil.cli", "--version")
    assert done.returncode == 0
    assert done.stdout.strip() == f"brake-hil {__version__}"


def _subparsers(top: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in top._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def test_every_option_of_every_command_has_help() -> None:
    missing = [
        f"{name} {action.dest}"
        for name, sub in _subparsers(build_parser()).items()
        for action in sub._actions
        if not action.help
    ]
    assert missing == []


def test_the_parsers_copies_of_simulator_values_agree() -> None:
    assert parser.EXCITATIONS == app_simulate.EXCITATIONS
    assert parser.LTI_EXCITATIONS == app_simulate.LTI_EXCITATIONS
    assert parser.SOLVER_METHOD == simulator.SOLVER_METHOD
    assert parser.RELATIVE_TOLERANCE == simulator.RELATIVE_TOLERANCE
    effect_help = next(
        a.help for a in _subparsers(build_parser())["simulate"]._actions if a.dest == "effect"
    )
    assert all(name in str(effect_help) for name in EFFECTS)


def test_help_imports_no_numerics() -> None:
    """``brake-hil --help`` (and each command's) loads neither numpy nor scipy: it is quick."""
    code = (
        "import sys\n"
        "from brake_hil.cli import main\n"
        "for argv in (['--help'], ['diagnose', '--help'], ['simulate', '--help']):\n"
        "    try:\n"
        "        main(argv)\n"
        "    except SystemExit as end:\n"
        "        assert end.code == 0\n"
        "print(sorted(m for m in ('numpy', 'scipy', 'matplotlib') if m in sys.modules))\n"
    )
    done = _run("-c", code)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "[]"


def test_rig_beside_a_recording(tmp_path: Path) -> None:
    (tmp_path / "run").mkdir()
    (tmp_path / "run.rig.yaml").write_text("x")
    (tmp_path / "bare.mcap").write_text("x")
    (tmp_path / "bare.rig.yaml").write_text("x")
    assert rig_beside(tmp_path / "run") == tmp_path / "run.rig.yaml"
    assert rig_beside(Path(f"{tmp_path}/run/")) == tmp_path / "run.rig.yaml"
    assert rig_beside(tmp_path / "bare.mcap") == tmp_path / "bare.rig.yaml"
    with pytest.raises(BrakeHilError, match="pass --rig"):
        rig_beside(tmp_path / "other")
    assert recording_name(Path("bags/one_washer_open/")) == "one_washer_open"
    assert recording_name(Path("x/run.mcap")) == "run"


def test_diagnose_without_a_rig_beside_exits_2_with_one_line(tmp_path: Path) -> None:
    (tmp_path / "rec").mkdir()
    done = _run("-m", "brake_hil.cli", "diagnose", str(tmp_path / "rec"))
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "pass --rig" in done.stderr


def test_empty_benchmark_categories_print_n_a() -> None:
    assert benchmark._figure(math.nan, 100.0, "6.1f", " %") == "   n/a  "
    assert benchmark._figure(0.5, 100.0, "6.1f", " %") == "  50.0 %"
    assert benchmark._figure(None, 1.0, ".1f") == "n/a"


def test_progress_off_a_terminal_is_whole_lines_never_past_the_total() -> None:
    stream = io.StringIO()
    with progress_bar(3, "work", "step", stream=stream) as bar:
        for _ in range(3):
            bar.update(1)
            bar.refresh()
    text = stream.getvalue()
    assert "\r" not in text
    lines = text.splitlines()
    assert lines and all(line.startswith("work:") for line in lines)
    assert "3/3" in lines[-1]


def test_benchmark_of_one_null_case_shows_progress_and_n_a_for_empty_categories(
    tmp_path: Path,
) -> None:
    made = _run(
        "-m", "brake_hil.cli", "cases", "--out", str(tmp_path), "--count", "1", "--seed", "5",
        "--kind", "null", "--pulsing-seconds", "2",
    )  # fmt: skip
    assert made.returncode == 0, made.stderr
    done = _run("-m", "brake_hil.cli", "benchmark", str(tmp_path))
    assert done.returncode == 0, done.stderr
    assert "nan" not in done.stdout
    single = next(line for line in done.stdout.splitlines() if line.startswith("top-1"))
    assert "n/a" in single and "of 0 cases" in single
    assert "benchmark:" in done.stderr and "1/1" in done.stderr  # progress, on stderr
    assert "\r" not in done.stderr


@pytest.mark.parametrize(
    ("options", "fragment"),
    [
        (["--excitation-hz", "50"], "outside 0.5-20 Hz"),
        (["--max-pressures", "2.0,1.0"], "2-5 increasing pressures"),
        (["--max-pressures", "1.5"], "2-5 increasing pressures"),
        (["--max-pressures", "1,x"], "comma-separated pressures in MPa"),
    ],
)
def test_cases_refuse_a_drive_out_of_range_with_exit_2_and_nothing_written(
    tmp_path: Path, options: list[str], fragment: str
) -> None:
    out = tmp_path / "set"
    done = _run("-m", "brake_hil.cli", "cases", "--out", str(out), "--count", "1", *options)
    assert done.returncode == 2
    assert fragment in done.stderr
    assert not out.exists()
