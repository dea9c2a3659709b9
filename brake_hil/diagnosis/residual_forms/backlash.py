"""Backlash: a play operator of fixed width on the prediction.

Hysteresis, a dead band on reversal (Krasnosel'skii and Pokrovskii, *Systems with
Hysteresis*, 1989).
"""

from __future__ import annotations

import numpy as np

from brake_hil.diagnosis.residual_forms.base import (
    CHANNEL_UNITS,
    ChannelSpans,
    FormContext,
    ResidualForm,
    quantity,
    register_form,
    warm_start,
)
from brake_hil.types import FloatArray


@register_form
class Backlash(ResidualForm):
    """``y = P_w[y_hat] + c0``: a play (backlash) operator of width ``w``."""

    name = "backlash"
    phrase = "hysteresis (a play of fixed width)"

    def parameter_units(self, unit: str) -> tuple[tuple[str, str], ...]:
        """Width of the play and offset."""
        return (("width", unit), ("offset", unit))

    def predict(self, x: FloatArray, data: ChannelSpans) -> FloatArray:
        """The play operator over each window, warmed up by one period."""
        parts = []
        for u in data.predicted:
            warm = warm_start(u, data.period_samples, 1)
            parts.append(play(warm, float(x[0]))[warm.size - u.size :])
        return np.asarray(np.concatenate(parts) + x[1], dtype=float)

    def starts(self) -> list[FloatArray]:
        """Widths from 0.5 % to 20 % of the channel's peak-to-peak."""
        return [np.array([w, 0.0]) for w in (0.005, 0.02, 0.05, 0.1, 0.2)]

    def bounds(self, size: int) -> tuple[FloatArray, FloatArray]:
        """Width between 0 and the channel's peak-to-peak."""
        return np.array([0.0, -np.inf]), np.array([1.0, np.inf])

    def natural(self, x: FloatArray, scale: float) -> tuple[float, ...]:
        """``w`` (unit), ``c0`` (unit)."""
        return (x[0] * scale, x[1] * scale)

    def detail(self, values: tuple[float, ...], channel: str, context: FormContext) -> str:
        """The play's width."""
        return f"width {quantity(values[0], CHANNEL_UNITS[channel])}"


def play(signal: FloatArray, width: float) -> FloatArray:
    """The play (backlash) operator of ``width`` (the signal's units), starting centred.

    ``y_k = min(max(y_{k-1}, u_k - w/2), u_k + w/2)``; on a monotone stretch that is
    ``max(y_start, u - w/2)`` (rising) or ``min(y_start, u + w/2)`` (falling), so the loop
    runs over the signal's reversals, not its samples.
    """
    half = 0.5 * width
    output = np.empty_like(signal)
    if signal.size == 0:
        return output
    output[0] = signal[0]
    steps = np.sign(np.diff(signal))
    if steps.size == 0:
        return output
    # A flat step keeps the direction before it.
    nonzero = np.flatnonzero(steps)
    if nonzero.size == 0:
        output[1:] = signal[0]
        return output
    filled = steps[
        nonzero[np.maximum(np.searchsorted(nonzero, np.arange(steps.size), "right") - 1, 0)]
    ]
    breaks = np.flatnonzero(np.diff(filled)) + 1
    previous = float(output[0])
    for first, last in zip(np.r_[0, breaks], np.r_[breaks, steps.size]):
        part = signal[first + 1 : last + 1]
        if filled[first] > 0:
            output[first + 1 : last + 1] = np.maximum(previous, part - half)
        else:
            output[first + 1 : last + 1] = np.minimum(previous, part + half)
        previous = float(output[last])
    return output
