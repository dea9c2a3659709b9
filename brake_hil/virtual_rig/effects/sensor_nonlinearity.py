"""sensor_nonlinearity: a transducer whose gain changes with its reading (out of the library)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from brake_hil.physics import catalogue
from brake_hil.physics.measurement import SENSORS
from brake_hil.types import FloatArray
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.effects.registry import register_effect
from brake_hil.virtual_rig.laws import LtiPlant, TruthLaw

NONLINEAR_CHANNELS = ("F_k",)
"""Only the load cell: a displacement probe whose gain grows with its reading is, seen from
the recording, the eccentric_load candidate's load-dependent share of the caliper force (both
scale ``x_c`` by ``1 + c p_b``), so it would not be out of the library."""


@dataclass(frozen=True)
class QuadraticGain(TruthLaw):
    """A channel read through ``v (1 + curvature v / full_scale)`` (SI).

    The host's acquisition port.
    """

    channel: str  # F_k
    curvature: float  # -, gain change at full scale
    full_scale: float  # N or m, the sensor's larger range limit

    def apply(self, time: FloatArray, values: FloatArray) -> FloatArray:
        """The channel as the transducer reports it (``time`` unused: a static law)."""
        del time
        return np.asarray(values * (1.0 + self.curvature * values / self.full_scale), dtype=float)

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        """The transducer's channel through :meth:`apply`; the others unchanged."""
        return self.apply(time, values) if channel == self.channel else values


@register_effect
@dataclass(frozen=True)
class SensorNonlinearity(Effect):
    """Sensor nonlinearity: load cells whose sensitivity changes with their reading.

    Causes: an overloaded strain-gauge bridge, a wrong calibration curve. ``F_k`` then reads
    ``v (1 + c v / full scale)``. Nothing in the caliper changes: the other channels stay
    consistent with each other and only this channel's peak-to-peak grows faster than the pressure.
    No candidate of the diagnosis library models a transducer's gain: a case with this effect is
    labelled ``unexplained``.
    Source: OIML R 60 (2000), load-cell non-linearity classes.
    """

    strength: float = 1.0
    channel: str = "F_k"
    curvature: float = 0.3

    entry = catalogue.entry("sensor_nonlinearity")
    parameters = (
        STRENGTH,
        Parameter("channel", "channel", 0.0, 0.0, "the channel read", choices=NONLINEAR_CHANNELS),
        Parameter("curvature", "-", 0.0, 1.0, "gain change at full scale, at strength 1"),
    )
    diagnosis_model = "none in the library (labelled unexplained)"

    def law(self, plant: LtiPlant) -> QuadraticGain:
        """The transducer's law at this strength (the same on every rig)."""
        del plant
        sensor = SENSORS[self.channel]
        return QuadraticGain(
            channel=self.channel,
            curvature=self.strength * self.curvature,
            full_scale=max(abs(sensor.low), abs(sensor.high)),
        )
