"""ROS 2 nodes: thin rclpy adapters around the core (each a launch-free console script)."""

from __future__ import annotations

__all__ = [
    "caliper_model",
    "chain",
    "common",
    "comparator",
    "container",
    "pressure_source",
    "recorder",
    "rig_emulator",
    "settings",
]
