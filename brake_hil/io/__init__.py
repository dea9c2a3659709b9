"""I/O layer: recordings (rosbag2 MCAP / bare MCAP / sqlite3), MCAP writing, CAN frames."""
