"""brake_hil: hardware-in-the-loop testing of hydraulic disk brakes (ROS 2 node suite).

``brake_hil.core`` is ROS-free physics, signals, identification and diagnosis (numpy/scipy);
``brake_hil.io`` reads and writes recordings; ``brake_hil.nodes`` are thin rclpy adapters.
"""

__version__ = "0.1.0"
