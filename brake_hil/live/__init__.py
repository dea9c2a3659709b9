"""Models that run live: what a live model is, and the model-file loaders. ROS-free.

The loaders read a rig YAML's LTI model and the diagnosis's improved model.
"""

from __future__ import annotations

__all__ = [
    "improved",
    "model",
    "model_file",
]
