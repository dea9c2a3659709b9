"""Fluid loss: a drift with the integral of the bore pressure.

A laminar leak ``Q = p_b / R_l`` loses volume in proportion to it.
"""

from __future__ import annotations

import numpy as np

from brake_hil.diagnosis.residual_forms.base import (
    CHANNEL_UNITS,
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
class FluidLoss(LinearForm):
    """``y = y_hat + c0 + k (V - V_ref)``, ``V`` the integral of ``p_b`` (a laminar leak)."""

    name = "fluid_loss"
    phrase = "fluid lost from the circuit (a drift with the integral of p_b)"

    def parameter_units(self, unit: str) -> tuple[tuple[str, str], ...]:
        """Offset and the drift per unit of bore-pressure integral."""
        return (("offset", unit), ("drift_per_pressure_integral", f"{unit}/(Pa s)"))

    def features(self, data: ChannelSpans) -> FloatArray:
        """``[1, V - V_ref]`` (MPa s)."""
        volume = np.concatenate(data.volume)
        return np.column_stack([np.ones_like(volume), volume])

    def natural(self, x: FloatArray, scale: float) -> tuple[float, ...]:
        """``c0`` (unit), ``k`` (unit/(Pa s))."""
        return (x[0] * scale, x[1] * scale / MEGA)

    def detail(self, values: tuple[float, ...], channel: str, context: FormContext) -> str:
        """The drift rate at the mean bore pressure."""
        rate = values[1] * context.bore_pressure
        pressure = quantity(context.bore_pressure, "Pa")
        return f"{quantity(rate, CHANNEL_UNITS[channel])}/s at {pressure} bore pressure"

    def constants(self, context: FormContext) -> tuple[FormParameter, ...]:
        """The reference bore-pressure integral the drift is about (Pa s)."""
        return (FormParameter("reference_pressure_integral", context.reference_volume, "Pa s"),)
