"""Small helpers the family-c laws share: smooth switches that work on floats and arrays."""

from __future__ import annotations

import math

import numpy as np

from brake_hil.virtual_rig.laws import LtiPlant, Signal

REFERENCE_AMPLITUDE = 0.3e6
"""Pa: the seed's pulsing amplitude at its lowest level (1.38 MPa max, 22 % of it)."""


def smooth_sign(value: Signal, width: float) -> Signal:
    """``tanh(value / width)``: a sign function rounded over ``width`` (same unit as value)."""
    if isinstance(value, float):
        return math.tanh(value / width)
    return np.tanh(value / width)


def smooth_abs(value: Signal, width: float) -> Signal:
    """``sqrt(value^2 + width^2) - width``: an absolute value rounded over ``width``."""
    if isinstance(value, float):
        return math.sqrt(value * value + width * width) - width
    return np.sqrt(value * value + width * width) - width


def positive_part(value: Signal, width: float) -> Signal:
    """``(value + |value|) / 2`` rounded over ``width``: about zero below, ``value`` above."""
    return 0.5 * (value + smooth_abs(value, width) + width)


def volume_compliance(plant: LtiPlant) -> float:
    """m^3/Pa: the volume the bore takes per pascal at 5 Hz, chamber and piston together.

    ``C_b`` plus the swept volume of the pistons, ``A_ep`` times the seal's and the caliper's
    displacement per pascal (their stiffnesses in series with the block, quasi-static).
    """
    params = plant.params
    caliper = params.bore_area / params.caliper_stiffness
    block = params.piston_area / params.block_stiffness
    seal = params.piston_area / max(params.effective_hydraulic_stiffness, 1.0)
    return params.bore_compliance + params.piston_area * (caliper + block + 0.5 * seal)


def reference_flow(plant: LtiPlant, frequency: float) -> float:
    """m^3/s: the flow amplitude through the line at the seed's pulsing (``frequency`` Hz)."""
    return 2.0 * math.pi * frequency * volume_compliance(plant) * REFERENCE_AMPLITUDE
