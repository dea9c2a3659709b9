"""Finding the physics the LTI model left out. ROS-free.

Candidate models and their engine, the calibration, fitting, evidence, the verdict and the
improved model's file.
"""

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
