"""Shared fixtures (the bundled rig files, the peer-data folder) and the ``slow`` marker.

``slow`` is given here, in one place, to the tests that start processes or ROS nodes, run a
diagnosis blind on whole recordings, or fuzz: ``pytest -m "not slow"`` is the inner loop,
``bash scripts/test.sh`` (and CI) runs everything. A test module joins the slow ones by its
path in ``SLOW_PATHS``, a single test by its name in ``SLOW_TESTS``, and every test that uses
a fixture of ``SLOW_FIXTURES`` or a parametrisation of ``SLOW_PARAMETERS`` is slow too.
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
"""Real files no one here wrote (rosbag2's own test bags): ``$BRAKE_HIL_PEER_DATA``, by default
the workplace's ``shared/peer-data`` folder beside the checkout; tests skip when absent."""

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
# Fast DDS reads its profile once, when this process makes its first participant: the test
# process's own nodes get the loopback profile (and its deep sample histories) from the start.
loopback_environment(os.environ)

SLOW_PATHS: tuple[str, ...] = (
    "test/nodes/",  # ROS 2 nodes in their own processes, over DDS
    "test/diagnosis/test_diagnose_blind.py",  # blind diagnoses of virtual-rig cases
    "test/diagnosis/test_diagnose_recorder_mcap.py",  # a recorder's MCAP through diagnose
    "test/diagnosis/test_slow_physics.py",  # slow seat creep and heating, fitted end to end
    "test/diagnosis/test_groove_diagnosis.py",  # a groove and stick-slip diagnosed whole
    "test/hostile/test_fuzz.py",  # the hypothesis fuzz of recordings and rig files
    "test/hostile/test_corpus.py",  # the hostile corpus through three commands
    "test/app/test_dask_engine.py",  # Dask clusters started for the test
    "test/cli/test_diagnose_many.py",  # brake-hil diagnose over many recordings on Dask
    "test/virtual_rig/test_fleet.py",  # a virtual lab recorded and diagnosed
    "test/results/test_trend_command.py",  # a fleet diagnosed for its trend
    "test/test_new_effect.py",  # a tenth effect recorded and diagnosed blind
    "test/cli/test_regress.py",  # the bundled recordings replayed in subprocesses
    "test/test_flake8.py",  # the ROS 2 linters over the tree (ruff checks the same rules)
    "test/test_pep257.py",
)
"""Test modules (paths from the checkout, a folder ending in ``/``) that are slow as a whole."""

SLOW_TESTS: tuple[str, ...] = (
    # brake-hil diagnose, benchmark or cases in a subprocess
    "test_diagnose_on_a_parameter_error_only_finds_no_missing_physics",
    "test_diagnose_and_benchmark_refuse_bad_input_with_one_line",
    "test_benchmark_of_one_null_case_shows_progress_and_n_a_for_empty_categories",
    "test_cases_command_writes_family_b_cases",
    "test_cases_command_writes_family_c_cases",
    "test_cases_writes_recordings_and_labels_apart",
    # blind diagnoses in this process
    "test_a_blind_diagnosis_of_a_strong_leak_names_no_library_effect",
    "test_an_internal_error_on_one_case_is_recorded_the_rest_scored_and_exit_is_1",
    "test_the_bundled_ramp_and_sweep_are_diagnosed",
    # the README's command blocks and benchmark scripts, each in a subprocess
    "test_readme_command_works_as_written",
    "test_each_benchmark_the_readme_names_starts_as_written",
    # a fresh interpreter per subpackage, rclpy blocked
    "test_core_imports_without_rclpy",
    # the stiff reference solver (Radau) on whole runs
    "test_batch_and_stepper_match_stiff_solver_on_rig_input",
    "test_air_driven_model_matches_stiff_solver",
)
"""Single slow tests, by function name (every parametrisation of it)."""

SLOW_FIXTURES: tuple[str, ...] = ("postgres_server", "postgres_url", "family_b_cases")
"""Fixtures that start a process of their own (a database server) or diagnose recordings."""

SLOW_PARAMETERS: tuple[str, ...] = ("postgresql",)
"""Parametrisations that start a process of their own (the PostgreSQL backend)."""


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
    parameters = getattr(getattr(item, "callspec", None), "params", {})
    return any(value in SLOW_PARAMETERS for value in parameters.values() if isinstance(value, str))


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark ``slow`` what the ``SLOW_*`` tuples above name."""
    del config
    for item in items:
        if _is_slow(item):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def default_rig() -> Rig:
    """The nominal one-washer rig of docs/physics.md."""
    return load_rig(CONFIG / "rig_default.yaml")
