"""ament_pep257 over the package's docstrings (ROS 2 standard).

The convention is Google's, as ruff's D rules check it (``ruff.toml``): magic methods and
``__init__`` are documented by their name and class (D105, D107); D402 is left to ruff,
because pydocstyle takes a word before a parenthesis in prose ("own states (none ...)") for
the function's signature. Tests are named as sentences and need no docstrings.
"""

from __future__ import annotations

from pathlib import Path

from ament_pep257.main import main
import pytest

PROJECT = Path(__file__).resolve().parents[1]


@pytest.mark.linter
@pytest.mark.pep257
def test_pep257() -> None:
    rc = main(
        argv=[
            str(PROJECT / "brake_hil"),
            "--convention",
            "google",
            "--add-ignore",
            "D105",
            "D107",
            "D402",
        ]
    )
    assert rc == 0, "Found code style errors / warnings"
