"""Shared fixtures: the bundled rig files and the peer-data folder beside the checkout."""

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


def pytest_configure(config: pytest.Config) -> None:
    """The markers of the ROS 2 linters' standard tests."""
    for marker in ("linter", "flake8", "pep257"):
        config.addinivalue_line("markers", f"{marker}: a ROS 2 ament linter test")


@pytest.fixture(scope="session")
def default_rig() -> Rig:
    """The nominal one-washer rig of physics.md."""
    return load_rig(CONFIG / "rig_default.yaml")
