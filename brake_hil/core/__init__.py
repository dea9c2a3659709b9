"""ROS-free core: physics, signals, identification and diagnosis (numpy/scipy only)."""
