"""Shared fixtures (the bundled rig files, the peer-data folder) and the ``slow`` marker.

``slow`` is given here, in one place, to the tests that start processes or ROS nodes, run a
diagnosis blind on whole recordings, or fuzz: ``pytest -m "not slow"`` is the inner loop,
``bash scripts/test.sh`` (and CI) runs everything. A test module joins the slow ones by its
path in ``SLOW_PATHS``, a single test by its name in ``SLOW_TESTS``, and every test that uses
a fixture of ``SLOW_FIXTURES`` is slow too.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from brake_hil.physics.rig import Rig, load_rig
from brake_hil.runtime import loopback_environment

PROJECT = Path(__file__).resolve().parents[1]
CONFIG = PROJECT / "config"
PEER_DATA = Path(os.environ.get("BRAKE_HIL_PEER_DATA", PROJECT.parent / "shared" / "peer-data"))

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
# Fast DDS reads its profile once, when this process makes its first participant: the test
# process's own nodes get the loopback profile (and its deep sample histories) from the start.
loopback_environment(os.environ)

SLOW_PATHS: tuple[str, ...] = (
    "test/nodes/",  # ROS 2 nodes in their own processes, over DDS
    "test/diagnosis/test_diagnose_blind.py",  # blind diagnoses of virtual-rig cases
    "test/diagnosis/test_diagnose_recorder_mcap.py",  # a recorder's MCAP through diagnose
    "test/diagnosis/test_slow_physics.py",  # slow seat creep and heating, fitted end to end
    "test/hostile/test_fuzz.py",  # the hypothesis fuzz of recordings and rig files
    "test/hostile/test_corpus.py",  # the hostile corpus through three commands
    "test/app/test_dask_engine.py",  # Dask clusters started for the test
    "test/cli/test_diagnose_many.py",  # brake-hil diagnose over many recordings on Dask
    "test/virtual_rig/test_fleet.py",  # a virtual lab recorded and diagnosed
    "test/results/test_trend_command.py",  # a fleet diagnosed for its trend
    "test/test_new_effect.py",  # a tenth effect recorded and diagnosed blind
)
"""Test modules (paths from the checkout, a folder ending in ``/``) that are slow as a whole."""

SLOW_TESTS: tuple[str, ...] = (
    "test_diagnose_on_a_parameter_error_only_finds_no_missing_physics",
    "test_diagnose_and_benchmark_refuse_bad_input_with_one_line",
)
"""Single slow tests, by function name: each runs ``brake-hil diagnose`` in a subprocess."""

SLOW_FIXTURES: tuple[str, ...] = ("postgres_server",)
"""Fixtures that start a process of their own (a database server)."""


def pytest_configure(config: pytest.Config) -> None:
    """The ROS 2 linters' markers and ``slow``."""
    for marker in ("linter", "flake8", "pep257"):
        config.addinivalue_line("markers", f"{marker}: a ROS 2 ament linter test")
    config.addinivalue_line(
        "markers", "slow: starts processes or nodes, diagnoses blind, or fuzzes (conftest.py)"
    )


def _is_slow(item: pytest.Item) -> bool:
    where = Path(str(item.path)).resolve().relative_to(PROJECT).as_posix()
    if any(where == path or where.startswith(path) for path in SLOW_PATHS if path):
        return True
    name = getattr(item, "originalname", item.name)
    if name in SLOW_TESTS:
        return True
    if any(fixture in getattr(item, "fixturenames", ()) for fixture in SLOW_FIXTURES):
        return True
    command = getattr(getattr(item, "callspec", None), "params", {}).get("command")
    if where == "test/test_readme.py" and isinstance(command, str):
        from test.test_readme import is_long

        return is_long(command)
    return False


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark the slow tests (``SLOW_PATHS``, ``SLOW_TESTS``, ``SLOW_FIXTURES``, long README blocks)."""
    del config
    for item in items:
        if _is_slow(item):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def default_rig() -> Rig:
    """The nominal one-washer rig of docs/physics.md."""
    return load_rig(CONFIG / "rig_default.yaml")
