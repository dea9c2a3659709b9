"""Measurement chain of a rig's DAQ: sensor noise and 16-bit quantisation over a range.

Ranges are the seed rig's sensors (a 6.9 MPa pressure transducer, three load cells, an
eddy-current displacement probe); the noise levels are typical of such sensors at 1 kHz.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from brake_hil.types import FloatArray


class Sensor(NamedTuple):
    """Range and noise of one channel (SI)."""

    low: float
    high: float
    noise_rms: float
    bits: int = 16

    @property
    def resolution(self) -> float:
        """One least-significant bit (SI)."""
        return (self.high - self.low) / float(2**self.bits - 1)


SENSORS: dict[str, Sensor] = {
    "p_i": Sensor(0.0, 6.9e6, 1.5e3),  # Pa
    "p_b": Sensor(0.0, 6.9e6, 1.5e3),  # Pa
    "F_k": Sensor(0.0, 8.9e3, 2.0),  # N
    "x_c": Sensor(-2.5e-4, 2.5e-4, 5.0e-8),  # m
    "p_a": Sensor(0.0, 1.0e6, 5.0e2),  # Pa
}


def measure(true_values: FloatArray, sensor: Sensor, rng: np.random.Generator) -> FloatArray:
    """Add white noise, then clip to the range and quantise to the sensor's bits."""
    noisy = true_values + rng.normal(0.0, sensor.noise_rms, size=np.shape(true_values))
    clipped = np.clip(noisy, sensor.low, sensor.high)
    counts = np.round((clipped - sensor.low) / sensor.resolution)
    return np.asarray(sensor.low + counts * sensor.resolution, dtype=float)
