"""What a live model is (ROS-free).

A per-sample stepper for the 1 kHz loop and a batch run of the same model.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from brake_hil.physics.parameters import ModelParameters
from brake_hil.types import FloatArray


class Stepper(Protocol):
    """What :class:`CatchUpRunner` steps: :class:`~brake_hil.physics.lti_model.CaliperStepper`."""

    def step(self, pressure: float) -> tuple[float, float, float]:
        """Advance one sample with input ``pressure`` (Pa); return ``(p_b, F_k, x_c)``."""
        ...


@dataclass(frozen=True)
class LiveModel:
    """A model ready to run live and in batch.

    ``stepper()`` makes a fresh per-sample stepper (starting from equilibrium at its first
    input); ``batch(pressure)`` returns the outputs ``(3, N)`` (``p_b`` Pa, ``F_k`` N,
    ``x_c`` m) of the same model on the input samples ``pressure`` (Pa), from the same start.
    """

    path: Path
    description: str
    mean_pressure: float  # Pa, the operating point the coefficients were derived at
    stepper: Callable[[], Stepper]
    batch: Callable[[FloatArray], FloatArray]
    parameters: ModelParameters | None = None  # LTI coefficients, when the model has them


ModelLoader = Callable[[Path, float], LiveModel]
"""Reads a model file at a mean master-cylinder pressure (Pa)."""

__all__ = ["LiveModel", "ModelLoader", "Stepper"]
