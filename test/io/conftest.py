"""Shared fixtures of the recording I/O tests: a synthetic rig run and the peer bags."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from brake_hil.topics import (
    BLOCK_FORCE,
    BORE_PRESSURE,
    CALIPER_DISPLACEMENT,
    MASTER_CYLINDER_PRESSURE,
    PREDICTED_BLOCK_FORCE,
    PREDICTED_BORE_PRESSURE,
    PREDICTED_CALIPER_DISPLACEMENT,
    TopicSpec,
)
from brake_hil.types import FloatArray
from test.conftest import PEER_DATA as ROOT_PEER_DATA

PEER_DATA = ROOT_PEER_DATA / "rosbag2"
"""rosbag2's own test bags, in the ``shared`` folder beside the repository checkout."""


def synthetic_run(
    duration: float = 3.0, rate: float = 1000.0, seed: int = 0
) -> tuple[FloatArray, dict[TopicSpec, FloatArray]]:
    """A 5 Hz pressure cycle with noisy measured outputs and model predictions.

    Returns time (s) and values per topic: pressures in Pa, force in N, displacement in m.
    """
    rng = np.random.default_rng(seed)
    time = np.arange(round(duration * rate)) / rate
    phase = 2 * np.pi * 5.0 * time
    p_i = 1.0e6 * (1 + np.sin(phase)) + rng.normal(0, 2e3, time.size)
    p_b = 0.95e6 * (1 + np.sin(phase - 0.2)) + rng.normal(0, 2e3, time.size)
    f_k = 1.2e3 * (1 + np.sin(phase - 0.25)) + rng.normal(0, 3.0, time.size)
    x_c = -2.0e-5 * (1 + np.sin(phase - 0.3)) + rng.normal(0, 1e-7, time.size)
    channels = {
        MASTER_CYLINDER_PRESSURE: p_i,
        BORE_PRESSURE: p_b,
        BLOCK_FORCE: f_k,
        CALIPER_DISPLACEMENT: x_c,
        PREDICTED_BORE_PRESSURE: 0.95e6 * (1 + np.sin(phase - 0.21)),
        PREDICTED_BLOCK_FORCE: 1.2e3 * (1 + np.sin(phase - 0.26)),
        PREDICTED_CALIPER_DISPLACEMENT: -2.0e-5 * (1 + np.sin(phase - 0.31)),
    }
    return time, channels


@pytest.fixture
def run() -> tuple[FloatArray, dict[TopicSpec, FloatArray]]:
    """Three seconds of the synthetic run at 1 kHz, all seven contract channels."""
    return synthetic_run()


@pytest.fixture
def peer_data() -> Path:
    """The peer bags' folder; the test is skipped when it is absent."""
    if not PEER_DATA.is_dir():
        pytest.skip(f"peer data not found at {PEER_DATA.resolve()}")
    return PEER_DATA


@pytest.fixture
def long_run() -> tuple[FloatArray, dict[TopicSpec, FloatArray]]:
    """Eighteen seconds of the synthetic run at 1 kHz (126 000 messages)."""
    return synthetic_run(duration=18.0)
