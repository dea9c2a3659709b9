"""A resonance: a second-order mode (20-150 Hz) on the prediction.

Driven by the predicted signal's acceleration (base excitation).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.signal

from brake_hil.diagnosis.engine.mechanisms import tustin_mode
from brake_hil.diagnosis.residual_forms.base import (
    ChannelSpans,
    FormContext,
    ResidualForm,
    register_form,
    warm_start,
)
from brake_hil.types import FloatArray


@register_form
class Resonance(ResidualForm):
    """``y = y_hat + g z + c0``, ``z'' + 2 zeta omega z' + omega^2 z = -y_hat''``: a mode."""

    name = "resonance"
    phrase = "a resonance (second-order mode)"
    lowest = 20.0  # Hz
    highest = 150.0  # Hz

    def parameter_units(self, unit: str) -> tuple[tuple[str, str], ...]:
        """Natural frequency, damping ratio, gain and offset."""
        return (("frequency", "Hz"), ("damping_ratio", "-"), ("gain", "-"), ("offset", unit))

    def predict(self, x: FloatArray, data: ChannelSpans) -> FloatArray:
        """The mode's relative motion, Tustin-discretised with the frequency prewarped."""
        frequency, zeta, gain = float(x[0]), float(np.exp(x[1])), float(x[2])
        dt = data.sample_time
        _, relative, a = tustin_mode(frequency, zeta, dt)
        b = -relative  # driven by -y_hat''
        decay = 5.0 / (zeta * 2.0 * math.pi * frequency)  # s
        periods = min(int(np.ceil(decay / (data.period_samples * dt))) + 1, 12)
        parts = []
        for u in data.predicted:
            warm = warm_start(u, data.period_samples, periods)
            mode = scipy.signal.lfilter(b, a, warm - warm[0])  # no response to a constant
            parts.append(u + gain * mode[warm.size - u.size :])
        return np.asarray(np.concatenate(parts) + x[3], dtype=float)

    def starts(self) -> list[FloatArray]:
        """Frequencies across the band, damping 0.1, no gain yet (then gain 1)."""
        return [
            np.array([f, np.log(z), g, 0.0])
            for f in (25.0, 40.0, 65.0, 100.0, 140.0)
            for z in (0.05, 0.2)
            for g in (0.5, -0.5)
        ]

    def bounds(self, size: int) -> tuple[FloatArray, FloatArray]:
        """20-150 Hz, damping ratio 0.02-1, gain within 10."""
        return (
            np.array([self.lowest, np.log(0.02), -10.0, -np.inf]),
            np.array([self.highest, 0.0, 10.0, np.inf]),
        )

    def natural(self, x: FloatArray, scale: float) -> tuple[float, ...]:
        """``f`` (Hz), ``zeta`` (-), ``g`` (-), ``c0`` (unit)."""
        return (float(x[0]), float(np.exp(x[1])), float(x[2]), x[3] * scale)

    def detail(self, values: tuple[float, ...], channel: str, context: FormContext) -> str:
        """Frequency and damping."""
        return f"{values[0]:.0f} Hz, damping ratio {values[1]:.2f}, gain {values[2]:.2f}"
