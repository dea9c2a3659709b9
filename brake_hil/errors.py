"""The one error hierarchy of brake_hil.

::

    BrakeHilError
     +-- RigError (BrakeHilError, ValueError)          a rig description is refused
     +-- RecordingError (BrakeHilError, ValueError)    a recording cannot be used
     |    +-- MissingTopicError                        a required topic is absent
     +-- SignalError (BrakeHilError, ValueError)       a signal is too short or not periodic

Each message names the file, key or topic and the problem, so the command line can print it
as one line and exit with status 2.
"""

from __future__ import annotations


class BrakeHilError(Exception):
    """Base of every error brake_hil raises on bad input."""


class RigError(BrakeHilError, ValueError):
    """A rig description (YAML) is missing a key, has an unknown key or an implausible value."""


class RecordingError(BrakeHilError, ValueError):
    """A recording is missing, truncated, corrupt, or holds unusable samples."""


class MissingTopicError(RecordingError):
    """A topic the command needs is not in the recording."""


class SignalError(BrakeHilError, ValueError):
    """A signal cannot be analysed (too short, no steady periodic segment, ...)."""
