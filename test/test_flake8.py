"""ament_flake8 over the package, its tests, setup.py and the benchmarks (ROS 2 standard)."""

from __future__ import annotations

from pathlib import Path

from ament_flake8.main import main_with_errors
import pytest

PROJECT = Path(__file__).resolve().parents[1]


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8() -> None:
    paths = [str(PROJECT / name) for name in ("brake_hil", "test", "benchmarks", "setup.py")]
    rc, errors = main_with_errors(argv=["--config", str(PROJECT / "setup.cfg"), *paths])
    assert rc == 0, f"Found {len(errors)} code style errors / warnings:\n" + "\n".join(errors)
