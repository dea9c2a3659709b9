"""The level gain: a gain that changes with the segment's mean pressure.

An amplitude-dependent stiffness or gain.
"""

from __future__ import annotations

import numpy as np

from brake_hil.diagnosis.residual_forms.base import (
    MEGA,
    ChannelSpans,
    FormContext,
    FormParameter,
    LinearForm,
    quantity,
    register_form,
)
from brake_hil.types import FloatArray


@register_form
class LevelGain(LinearForm):
    """``y = (1 + g0 + g1 (p_seg - p_ref)) y_hat + c0``: a gain that changes with the level."""

    name = "level_gain"
    phrase = "a gain that changes with the pressure level"

    def parameter_units(self, unit: str) -> tuple[tuple[str, str], ...]:
        """Gain change at the reference pressure, its slope in pressure, offset."""
        return (("gain_change", "-"), ("gain_per_pressure", "1/Pa"), ("offset", unit))

    def features(self, data: ChannelSpans) -> FloatArray:
        """``[u, u (p_seg - p_ref), 1]`` (pressure in MPa)."""
        u = data.baseline
        level = np.concatenate([np.full(p.size, q) for p, q in zip(data.predicted, data.level)])
        return np.column_stack([u, u * level, np.ones_like(u)])

    def natural(self, x: FloatArray, scale: float) -> tuple[float, ...]:
        """``g0`` (-), ``g1`` (1/Pa), ``c0`` (unit)."""
        return (x[0], x[1] / MEGA, x[2] * scale)

    def detail(self, values: tuple[float, ...], channel: str, context: FormContext) -> str:
        """The gain at the lowest and the highest level."""
        g0, g1, _ = values
        low, high = context.pressure_range

        def gain(p: float) -> float:
            return 1.0 + g0 + g1 * (p - context.reference_pressure)

        return (
            f"gain {gain(low):.3f} at {quantity(low, 'Pa')} to {gain(high):.3f} at "
            f"{quantity(high, 'Pa')} mean p_i"
        )

    def constants(self, context: FormContext) -> tuple[FormParameter, ...]:
        """The reference pressure the gain's slope is about (Pa)."""
        return (FormParameter("reference_pressure", context.reference_pressure, "Pa"),)
