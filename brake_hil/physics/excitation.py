"""The seed's excitation: ramp to a maximum pressure, then 5 Hz pulsing.

The seed's rig ramps the master-cylinder pressure up, then a 3-way solenoid pulses the air
at 5 Hz; a run may hold several maximum pressures (1.38, 2.07, 2.76 MPa). One
:class:`PulsingSchedule` describes such a run; the core's sine (:meth:`PulsingSchedule.profile`,
:func:`pulsing_profile`), the virtual rig's inputs (``seed_pulsing``, ``solenoid_pulsing``) and
the rig emulator node all build from it. The pulsing here is a sine about ``max_pressure -
amplitude`` with ``amplitude = amplitude_fraction * max_pressure`` (0.22 gives the seed's
~0.6 MPa peak-to-peak at 1.38 MPa).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from brake_hil.types import FloatArray

SEED_MAX_PRESSURES = (1.38e6, 2.07e6, 2.76e6)
"""Maximum master-cylinder pressures of the seed's experiments (Pa)."""

SAMPLE_RATE_HZ = 1000.0
"""Sample rate of the rig's acquisition (Hz)."""

__all__ = [
    "DEFAULT_SCHEDULE",
    "SAMPLE_RATE_HZ",
    "SEED_MAX_PRESSURES",
    "PulsingSchedule",
    "Segment",
    "pulsing_profile",
]


class Segment(NamedTuple):
    """One ramp-then-pulse segment of a :class:`PulsingSchedule` (pressures in Pa)."""

    start: float  # level the ramp starts from: the previous segment's mean, 0 for the first
    mean: float  # pulsing mean, max_pressure - amplitude
    amplitude: float  # pulsing amplitude, amplitude_fraction * max_pressure


@dataclass(frozen=True)
class PulsingSchedule:
    """A ramp-then-pulse run: per maximum pressure, a ramp to the pulsing mean, then pulsing.

    Each segment ramps (a half cosine, smooth at both ends) from the previous segment's mean
    (zero gauge pressure for the first) to its own mean ``max_pressure - amplitude`` over
    ``ramp_s``, then pulses ``+- amplitude`` about it for ``pulsing_s`` at ``pulsing_hz``.
    """

    max_pressures: tuple[float, ...] = (1.38e6,)  # Pa, one segment each
    ramp_s: float = 1.0  # s, the ramp of each segment
    pulsing_s: float = 5.0  # s, the pulsing of each segment
    pulsing_hz: float = 5.0  # Hz, f_e
    amplitude_fraction: float = 0.22  # amplitude over the maximum pressure
    sample_rate_hz: float = SAMPLE_RATE_HZ  # Hz

    def __post_init__(self) -> None:
        object.__setattr__(self, "max_pressures", tuple(float(p) for p in self.max_pressures))

    @property
    def ramp_samples(self) -> int:
        """Samples of each segment's ramp."""
        return int(round(self.ramp_s * self.sample_rate_hz))

    @property
    def pulsing_samples(self) -> int:
        """Samples of each segment's pulsing."""
        return int(round(self.pulsing_s * self.sample_rate_hz))

    @property
    def samples(self) -> int:
        """Samples of the whole run."""
        return len(self.max_pressures) * (self.ramp_samples + self.pulsing_samples)

    @property
    def segments(self) -> tuple[Segment, ...]:
        """Start level, pulsing mean and amplitude (Pa) of each segment, in order."""
        segments: list[Segment] = []
        level = 0.0
        for max_pressure in self.max_pressures:
            amplitude = self.amplitude_fraction * max_pressure
            mean = max_pressure - amplitude
            segments.append(Segment(level, mean, amplitude))
            level = mean
        return tuple(segments)

    @property
    def levels_mpa(self) -> str:
        """The maximum pressures in MPa, for labels: ``"1.38, 2.76"``."""
        return ", ".join(f"{p / 1e6:.2f}" for p in self.max_pressures)

    def ramp_shape(self) -> FloatArray:
        """A ramp's shape from 0 to 1 (half cosine), at the sample rate."""
        ramp = np.arange(self.ramp_samples) / self.sample_rate_hz
        shape: FloatArray = 0.5 - 0.5 * np.cos(np.pi * ramp / self.ramp_s)
        return shape

    def scaled(self, gain: float) -> PulsingSchedule:
        """The same schedule with every maximum pressure times ``gain`` (e.g. ``A_i / A_a``)."""
        return replace(self, max_pressures=tuple(p * gain for p in self.max_pressures))

    def at_rate(self, sample_rate_hz: float) -> PulsingSchedule:
        """The same schedule sampled at ``sample_rate_hz`` (Hz)."""
        return replace(self, sample_rate_hz=sample_rate_hz)

    def profile(self) -> tuple[FloatArray, FloatArray]:
        """Time (s, from 0) and master-cylinder pressure (Pa): the sine pulsing."""
        shape = self.ramp_shape()
        pulse = np.arange(self.pulsing_samples) / self.sample_rate_hz
        sine = np.sin(2.0 * np.pi * self.pulsing_hz * pulse)
        pieces: list[FloatArray] = []
        for segment in self.segments:
            pieces.append(segment.start + (segment.mean - segment.start) * shape)
            pieces.append(segment.mean + segment.amplitude * sine)
        pressure = np.concatenate(pieces)
        return np.arange(pressure.size) / self.sample_rate_hz, pressure


DEFAULT_SCHEDULE = PulsingSchedule()
"""One segment at 1.38 MPa: 1 s of ramp, 5 s of 5 Hz pulsing at 1 kHz."""


def pulsing_profile(
    max_pressures: Sequence[float] = (1.38e6,),
    sample_rate_hz: float = SAMPLE_RATE_HZ,
    ramp_s: float = 1.0,
    pulsing_s: float = 5.0,
    pulsing_hz: float = 5.0,
    amplitude_fraction: float = 0.22,
) -> tuple[FloatArray, FloatArray]:
    """Time (s) and master-cylinder pressure (Pa) of ramp-then-pulse segments in a row.

    The :meth:`PulsingSchedule.profile` of these arguments.
    """
    schedule = PulsingSchedule(
        tuple(max_pressures),
        ramp_s=ramp_s,
        pulsing_s=pulsing_s,
        pulsing_hz=pulsing_hz,
        amplitude_fraction=amplitude_fraction,
        sample_rate_hz=sample_rate_hz,
    )
    return schedule.profile()
