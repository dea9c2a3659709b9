"""Finding the physics the LTI model left out. ROS-free.

Candidate models and their engine, the calibration, fitting, evidence, the generic forms of a
misfit, the verdict, its physics checks, and the result with the improved model's file
(docs/diagnosis.md).
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
    "physics_checks",
    "residual_forms",
    "result",
    "summary",
    "thresholds",
    "verdict",
]
