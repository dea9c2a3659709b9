"""The one error hierarchy of brake_hil: every error it raises on bad input, in one place.

::

    BrakeHilError
     +-- RigError (ValueError)              a rig description is refused
     +-- RecordingError (ValueError)        a recording cannot be used
     |    +-- MissingTopicError             a required topic is absent
     +-- RecordingWriteError                a recording cannot be written on (disk full)
     +-- SignalError (ValueError)           a signal is too short or not periodic
     |    +-- NoSteadyPulsingError          no steady 5 Hz pulsing to score
     +-- ModelFileError (ValueError)        a model file is missing or of an unknown kind
     +-- ImprovedModelError (ValueError)    an improved_model.json is malformed
     +-- BaselineError (ValueError)         a regression baseline is missing or malformed
     +-- OutputError (ValueError)           an output file or folder cannot be written
     +-- EffectError (ValueError)           an effect is unknown, doubled or out of bounds
     +-- SimulationError (RuntimeError)     the virtual rig's solver failed
     +-- FitError (ArithmeticError)         a model's simulation is not finite where a fit starts
     +-- DdsSecurityError                   DDS security asked for, and this DDS cannot give it
     +-- CanDaqError                        a CAN acquisition cannot be set up
          +-- DbcError (ValueError)         the CAN database does not describe rig frames
          +-- FrameError (ValueError)       one received frame is refused
               +-- UnknownFrameError        its id is not in the DBC
               +-- FrameLengthError         its DLC differs from the DBC's
               +-- ChecksumError            its crc8 does not match

Each message names the file, key or topic and the problem, so the command line can print it
as one line and exit with status 2.
"""

from __future__ import annotations

__all__ = [
    "BaselineError",
    "BrakeHilError",
    "CanDaqError",
    "ChecksumError",
    "DbcError",
    "DdsSecurityError",
    "EffectError",
    "FrameError",
    "FitError",
    "FrameLengthError",
    "ImprovedModelError",
    "MissingTopicError",
    "ModelFileError",
    "NoSteadyPulsingError",
    "OutputError",
    "RecordingError",
    "RecordingWriteError",
    "RigError",
    "SignalError",
    "SimulationError",
    "UnknownFrameError",
]


class BrakeHilError(Exception):
    """Base of every error brake_hil raises on bad input."""


class RigError(BrakeHilError, ValueError):
    """A rig description (YAML) is missing a key, has an unknown key or an implausible value."""


class RecordingError(BrakeHilError, ValueError):
    """A recording is missing, truncated, corrupt, or holds unusable samples."""


class MissingTopicError(RecordingError):
    """A topic the command needs is not in the recording."""


class RecordingWriteError(BrakeHilError):
    """Writing a recording failed (disk full, file size limit, I/O error)."""


class SignalError(BrakeHilError, ValueError):
    """A signal cannot be analysed (too short, no steady periodic segment, ...)."""


class NoSteadyPulsingError(SignalError):
    """A recording holds no steady 5 Hz pulsing (a ramp, a sweep): nothing to score."""


class ModelFileError(BrakeHilError, ValueError):
    """A model file is missing or of a kind no loader reads."""


class ImprovedModelError(BrakeHilError, ValueError):
    """An improved-model file is missing, malformed or names an unknown effect."""


class BaselineError(BrakeHilError, ValueError):
    """A baseline file is missing, unreadable or malformed."""


class OutputError(BrakeHilError, ValueError):
    """An output file or folder cannot be written, or is a link leading out of its folder."""


class EffectError(BrakeHilError, ValueError):
    """An effect is unknown, named twice, or has a parameter outside its bounds."""


class SimulationError(BrakeHilError, RuntimeError):
    """The virtual rig's solver failed (it names the time reached and the solver's message)."""


class FitError(BrakeHilError, ArithmeticError):
    """A candidate model cannot be fitted: its simulation is not finite at the fit's start."""


class DdsSecurityError(BrakeHilError):
    """``ROS_SECURITY_ENABLE=true``, and the DDS has no security plugins."""


class CanDaqError(BrakeHilError):
    """A CAN acquisition cannot be set up."""


class DbcError(CanDaqError, ValueError):
    """The CAN database is missing or does not describe rig frames."""


class FrameError(CanDaqError, ValueError):
    """One received frame is refused."""


class UnknownFrameError(FrameError):
    """The frame's id is not in the DBC (or it is a remote frame)."""


class FrameLengthError(FrameError):
    """The frame's DLC differs from the DBC's length."""


class ChecksumError(FrameError):
    """The frame's crc8 does not match its content."""
