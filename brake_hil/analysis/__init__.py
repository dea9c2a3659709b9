"""Recordings as arrays and what the seed measures on them. ROS-free.

Signals and Table 4-5 metrics, characterisation (Table 3), compare, the comparator's
stamp-paired scoring.
"""

from __future__ import annotations

__all__ = [
    "characterization",
    "comparison",
    "recording",
    "signals",
    "stamp_scoring",
]
