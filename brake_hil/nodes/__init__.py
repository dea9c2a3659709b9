"""ROS 2 nodes: thin rclpy adapters around the core (each a launch-free console script)."""
