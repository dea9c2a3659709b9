"""sensor_nonlinearity: a transducer whose gain changes with its reading (out of the library)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from brake_hil.physics.measurement import SENSORS
from brake_hil.types import FloatArray
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter

if TYPE_CHECKING:
    from brake_hil.virtual_rig.plant import Plant

NONLINEAR_CHANNELS = ("F_k",)
"""Only the load cell: a displacement probe whose gain grows with its reading is, seen from
the recording, the eccentric_load candidate's load-dependent share of the caliper force (both
scale ``x_c`` by ``1 + c p_b``), so it would not be out of the library."""


@dataclass(frozen=True)
class QuadraticGain:
    """A channel read through ``v (1 + curvature v / full_scale)`` (SI)."""

    channel: str  # F_k
    curvature: float  # -, gain change at full scale
    full_scale: float  # N or m, the sensor's larger range limit

    def apply(self, time: FloatArray, values: FloatArray) -> FloatArray:
        """The channel as the transducer reports it (``time`` unused: a static law)."""
        del time
        return np.asarray(values * (1.0 + self.curvature * values / self.full_scale), dtype=float)


@dataclass(frozen=True)
class SensorNonlinearity(Effect):
    """Sensor nonlinearity: load cells whose sensitivity changes with their reading (an
    overloaded strain-gauge bridge, a wrong calibration curve), so ``F_k`` reads
    ``v (1 + c v / full scale)``. Nothing in
    the caliper changes: the other channels stay consistent with each other and only this
    channel's peak-to-peak grows faster than the pressure. No candidate of the diagnosis
    library models a transducer's gain: a case with this effect is labelled ``unexplained``.
    Source: OIML R 60 (2000), load-cell non-linearity classes.
    """

    strength: float = 1.0
    channel: str = "F_k"
    curvature: float = 0.3

    name = "sensor_nonlinearity"
    parameters = (
        STRENGTH,
        Parameter("channel", "channel", 0.0, 0.0, "the channel read", choices=NONLINEAR_CHANNELS),
        Parameter("curvature", "-", 0.0, 1.0, "gain change at full scale, at strength 1"),
    )
    signature = (
        "one output's amplitude ratio to the others grows with the pressure; its phase and "
        "the other channels unchanged"
    )
    diagnosis_model = "none in the library (labelled unexplained)"

    def law(self) -> QuadraticGain:
        """The transducer's law at this strength."""
        sensor = SENSORS[self.channel]
        return QuadraticGain(
            channel=self.channel,
            curvature=self.strength * self.curvature,
            full_scale=max(abs(sensor.low), abs(sensor.high)),
        )

    def install(self, plant: Plant) -> Plant:
        """Measurement slot: the channel's transducer law."""
        if not self.active:
            return plant
        return replace(plant, skews=(*plant.skews, self.law()))
