"""Topic names, message types and fields, and the effect names, of the interface contract.

The contract is interface.md.
"""

from __future__ import annotations

from typing import NamedTuple


class TopicSpec(NamedTuple):
    """Where one quantity lives on the ROS graph and in recordings."""

    name: str
    msgtype: str  # ROS 2 type name, e.g. "sensor_msgs/msg/FluidPressure"
    field: str  # dotted path of the value inside the message
    quantity: str  # the paper's symbol


MASTER_CYLINDER_PRESSURE = TopicSpec(
    "/brake/master_cylinder/pressure", "sensor_msgs/msg/FluidPressure", "fluid_pressure", "p_i"
)
BORE_PRESSURE = TopicSpec(
    "/brake/bore/pressure", "sensor_msgs/msg/FluidPressure", "fluid_pressure", "p_b"
)
BLOCK_FORCE = TopicSpec(
    "/brake/block/force", "geometry_msgs/msg/WrenchStamped", "wrench.force.z", "F_k"
)
CALIPER_DISPLACEMENT = TopicSpec(
    "/brake/caliper/displacement", "geometry_msgs/msg/Vector3Stamped", "vector.z", "x_c"
)
AIR_PRESSURE = TopicSpec(
    "/brake/air/pressure", "sensor_msgs/msg/FluidPressure", "fluid_pressure", "p_a"
)
PREDICTED_BORE_PRESSURE = BORE_PRESSURE._replace(name="/brake/model/bore/pressure")
PREDICTED_BLOCK_FORCE = BLOCK_FORCE._replace(name="/brake/model/block/force")
PREDICTED_CALIPER_DISPLACEMENT = CALIPER_DISPLACEMENT._replace(
    name="/brake/model/caliper/displacement"
)

MEASURED_OUTPUTS = (BORE_PRESSURE, BLOCK_FORCE, CALIPER_DISPLACEMENT)
"""The measured model outputs, in the order p_b, F_k, x_c."""
PREDICTED_OUTPUTS = (
    PREDICTED_BORE_PRESSURE,
    PREDICTED_BLOCK_FORCE,
    PREDICTED_CALIPER_DISPLACEMENT,
)
"""The model's predictions of the same quantities, same order."""
ALL_TOPICS = (MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS, AIR_PRESSURE, *PREDICTED_OUTPUTS)
QUANTITY_TOPICS: dict[str, TopicSpec] = {
    spec.quantity: spec for spec in (MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS, AIR_PRESSURE)
}
"""The measured topic of each quantity (``p_i``, ``p_b``, ``F_k``, ``x_c``, ``p_a``)."""

OUTPUT_CHANNELS = ("p_b", "F_k", "x_c")
"""Channel keys used in metrics and JSON."""
