"""Models that run live: what a live model is, and the model-file loaders (a rig YAML's LTI
model, the diagnosis's improved model). ROS-free."""

from __future__ import annotations

__all__ = [
    "improved",
    "model",
    "model_file",
]
