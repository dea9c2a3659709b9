"""Results over time: every run's numbers in a database, and the rig's health from them.

:mod:`.identity` knows a recording by its content and the rig file by its bytes;
:mod:`.store` keeps each diagnosis, regression and comparison in SQLite or PostgreSQL
(:mod:`.backends`); :mod:`.trend` reads the diagnoses of one rig in time order and says in
plain words which calibrated value or effect left its tolerance.
"""

from __future__ import annotations

__all__ = [
    "identity",
    "store",
    "trend",
]
