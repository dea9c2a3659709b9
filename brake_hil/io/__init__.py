"""I/O layer: recordings (rosbag2 MCAP / bare MCAP / sqlite3), MCAP writing, CAN frames."""

from __future__ import annotations

__all__ = [
    "can_daq",
    "mcap_recorder",
    "recording_checks",
    "recording_reader",
    "recording_writer",
    "stamped_cdr",
]
