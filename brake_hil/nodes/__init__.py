"""ROS 2 nodes: thin rclpy adapters around the core (each a launch-free console script).

Each node ``NAME`` has an entry module ``NAME`` (its documentation, ``main``: the help
answered without rclpy) and its ROS side ``NAME_node`` (the rclpy node class), imported only
to run it.
"""

from __future__ import annotations

__all__ = [
    "caliper_model",
    "caliper_model_node",
    "chain",
    "common",
    "comparator",
    "comparator_node",
    "container",
    "container_node",
    "entry",
    "pressure_source",
    "pressure_source_node",
    "recorder",
    "recorder_node",
    "rig_emulator",
    "rig_emulator_node",
    "settings",
    "spinning",
]
