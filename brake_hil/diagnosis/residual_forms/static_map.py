"""The static map: a cubic static nonlinearity of the prediction.

A transducer or a stiffness whose gain changes with its reading.
"""

from __future__ import annotations

import numpy as np

from brake_hil.diagnosis.residual_forms.base import (
    CHANNEL_UNITS,
    ChannelSpans,
    FormContext,
    LinearForm,
    quantity,
    register_form,
)
from brake_hil.types import FloatArray


@register_form
class StaticMap(LinearForm):
    """``y = y_hat + c0 + c1 y_hat + c2 y_hat^2 + c3 y_hat^3``: a cubic static nonlinearity."""

    name = "static_map"
    phrase = "a static nonlinear map"

    def parameter_units(self, unit: str) -> tuple[tuple[str, str], ...]:
        """Offset, gain change, quadratic and cubic coefficients."""
        return (
            ("offset", unit),
            ("gain_change", "-"),
            ("quadratic", f"1/{unit}"),
            ("cubic", f"1/{unit}^2"),
        )

    def features(self, data: ChannelSpans) -> FloatArray:
        """``[1, u, u^2, u^3]`` of the normalised prediction ``u``."""
        u = data.baseline
        return np.column_stack([np.ones_like(u), u, u**2, u**3])

    def natural(self, x: FloatArray, scale: float) -> tuple[float, ...]:
        """``c0`` (unit), ``c1`` (-), ``c2`` (1/unit), ``c3`` (1/unit^2)."""
        return (x[0] * scale, x[1], x[2] / scale, x[3] / scale**2)

    def detail(self, values: tuple[float, ...], channel: str, context: FormContext) -> str:
        """The local gain ``dy/dy_hat`` at the smallest and the largest reading."""
        _, c1, c2, c3 = values
        unit = CHANNEL_UNITS[channel]
        low, high = context.prediction_range[channel]

        def gain(v: float) -> float:
            return 1.0 + c1 + 2.0 * c2 * v + 3.0 * c3 * v**2

        return (
            f"cubic; gain {gain(low):.3f} at {quantity(low, unit)} to "
            f"{gain(high):.3f} at {quantity(high, unit)}"
        )
