"""Shared runs of the virtual rig: short recordings, each simulated once per session."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import cache
from typing import Any

import pytest

from brake_hil.physics.rig import Rig, load_rig
from brake_hil.virtual_rig import RigRun, make_effect, seed_pulsing, simulate_rig
from test.conftest import CONFIG

RunFactory = Callable[..., RigRun]


@cache
def _run(
    rig_file: str,
    effects: tuple[tuple[str, float, tuple[tuple[str, float | str], ...]], ...],
    max_pressures: tuple[float, ...],
    pulsing_s: float,
) -> RigRun:
    rig = load_rig(CONFIG / rig_file)
    made = [make_effect(name, strength, **dict(params)) for name, strength, params in effects]
    return simulate_rig(rig, made, seed_pulsing(max_pressures, pulsing_s=pulsing_s))


def _effect_key(
    name: str, strength: float, parameters: dict[str, float | str] | None = None
) -> tuple[str, float, tuple[tuple[str, float | str], ...]]:
    return name, strength, tuple(sorted((parameters or {}).items()))


@pytest.fixture(scope="session")
def rig_run() -> RunFactory:
    """``rig_run(("orifice_flow", 1.0), max_pressures=(2.76e6,), pulsing_s=3.0)``: a cached run.

    Each effect is ``(name, strength)`` or ``(name, strength, {param: value})``; the rig is
    config/rig_default.yaml unless ``rig_file`` names another.
    """

    def factory(
        *effects: tuple[Any, ...],
        max_pressures: Sequence[float] = (1.38e6,),
        pulsing_s: float = 3.0,
        rig_file: str = "rig_default.yaml",
    ) -> RigRun:
        key = tuple(_effect_key(*effect) for effect in effects)
        return _run(rig_file, key, tuple(max_pressures), pulsing_s)

    return factory


@pytest.fixture(scope="session")
def nominal_rig() -> Rig:
    """config/rig_default.yaml."""
    return load_rig(CONFIG / "rig_default.yaml")
