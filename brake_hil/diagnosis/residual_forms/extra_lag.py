"""An extra lag: a first-order lag ``tau y' + y = y_hat`` on the prediction."""

from __future__ import annotations

import math

import numpy as np
import scipy.signal

from brake_hil.diagnosis.residual_forms.base import (
    ChannelSpans,
    FormContext,
    ResidualForm,
    register_form,
    warm_start,
)
from brake_hil.types import FloatArray


@register_form
class ExtraLag(ResidualForm):
    """``y = L_tau[y_hat] + c0``: an extra first-order lag ``tau y' + y = y_hat``."""

    name = "extra_lag"
    phrase = "an extra lag (first order)"
    shortest = 1e-4  # s
    longest = 0.2  # s

    def parameter_units(self, unit: str) -> tuple[tuple[str, str], ...]:
        """Time constant and offset."""
        return (("time_constant", "s"), ("offset", unit))

    def predict(self, x: FloatArray, data: ChannelSpans) -> FloatArray:
        """The lag, exact for a linearly interpolated input, warmed up over five time constants."""
        tau = float(np.exp(x[0]))
        pole = math.exp(-data.sample_time / tau)
        ramp = tau / data.sample_time * (1.0 - pole)  # first-order hold (Franklin & Powell)
        b, a = [1.0 - ramp, ramp - pole], [1.0, -pole]
        periods = min(int(np.ceil(5 * tau / (data.period_samples * data.sample_time))) + 1, 10)
        parts = []
        for u in data.predicted:
            warm = warm_start(u, data.period_samples, periods)
            start = scipy.signal.lfilter_zi(b, a) * warm[0]
            lagged = scipy.signal.lfilter(b, a, warm, zi=start)[0]
            parts.append(lagged[warm.size - u.size :])
        return np.asarray(np.concatenate(parts) + x[1], dtype=float)

    def starts(self) -> list[FloatArray]:
        """Time constants from 0.5 ms to 50 ms."""
        return [np.array([np.log(t), 0.0]) for t in (5e-4, 2e-3, 8e-3, 2e-2, 5e-2)]

    def bounds(self, size: int) -> tuple[FloatArray, FloatArray]:
        """``tau`` between 0.1 ms and 0.2 s."""
        return (
            np.array([np.log(self.shortest), -np.inf]),
            np.array([np.log(self.longest), np.inf]),
        )

    def natural(self, x: FloatArray, scale: float) -> tuple[float, ...]:
        """``tau`` (s), ``c0`` (unit)."""
        return (float(np.exp(x[0])), x[1] * scale)

    def detail(self, values: tuple[float, ...], channel: str, context: FormContext) -> str:
        """The time constant."""
        return f"time constant {1e3 * values[0]:.1f} ms"
