"""Finding the physics the LTI model left out: candidate models and their engine, the
calibration, fitting, evidence, the verdict and the improved model's file. ROS-free."""

from __future__ import annotations

__all__ = [
    "calibration",
    "candidates",
    "dataset",
    "diagnose",
    "engine",
    "evidence",
    "fitting",
    "improved_model",
]
