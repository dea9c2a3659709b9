"""Family c's sensor delay: a transport lag realised as a fractional-delay (Thiran) filter."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.signal import lfilter, lfilter_zi

from brake_hil.types import FloatArray
from brake_hil.virtual_rig.effects.base import STRENGTH, Parameter
from brake_hil.virtual_rig.family_c.base import FamilyCEffect, register_effect_c
from brake_hil.virtual_rig.laws import LtiPlant, TruthLaw

MEASURED = ("p_b", "F_k", "x_c")


def fractional_delay(values: FloatArray, samples: float) -> FloatArray:
    """``values`` delayed by ``samples`` (>= 0): whole samples shifted, the rest by Thiran.

    The fraction goes through a first-order Thiran all-pass (maximally flat group delay,
    Thiran 1971), whose coefficient for a delay ``D`` in ``[0.5, 1.5)`` is
    ``(1 - D) / (1 + D)``; the history before the first sample holds its value.
    """
    whole = int(np.floor(samples - 0.5)) if samples >= 0.5 else 0
    fraction = samples - whole
    shifted = np.concatenate((np.full(whole, values[0]), values[: values.size - whole]))
    if fraction < 1e-9:
        return shifted
    coefficient = (1.0 - fraction) / (1.0 + fraction)
    b, a = [coefficient, 1.0], [1.0, coefficient]
    out, _ = lfilter(b, a, shifted, zi=lfilter_zi(b, a) * values[0])
    return np.asarray(out, dtype=float)


@dataclass(frozen=True)
class _LaggingChannel(TruthLaw):
    channel: str
    delay: float  # s

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        if channel != self.channel or values.size < 2:
            return values
        step = float(np.median(np.diff(time)))
        return fractional_delay(values, self.delay / step)


@register_effect_c
@dataclass(frozen=True)
class SensorDelayC(FamilyCEffect, effect="sensor_delay"):
    """A transport lag in one channel's chain, a whole number of samples plus a fraction.

    A channel whose DAQ path buffers (a CAN gateway, a multiplexer's slot, a digital filter's
    group delay) arrives ``d`` later than ``p_i``; the whole samples are a shift and the
    fraction a first-order Thiran all-pass, flat in group delay at the pulsing's harmonics.
    """

    channel: str = "x_c"
    delay: float = 4.0e-3

    parameters: ClassVar[tuple[Parameter, ...]] = (
        STRENGTH,
        Parameter("channel", "channel", 0.0, 0.0, "the lagging channel", MEASURED),
        Parameter("delay", "s", 2.0e-4, 2.0e-2, "the channel's lag d at full strength"),
    )
    diagnosis_model: ClassVar[str] = "a pure delay of one channel, as the truth"

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> SensorDelayC:
        """This law at ``strength``, its own parameters drawn from ``rng`` (a case's draw)."""
        channel = str(rng.choice(MEASURED))
        return cls(
            strength=strength, channel=channel, delay=float(np.round(rng.uniform(3e-3, 5e-3), 5))
        )

    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""
        del plant
        return _LaggingChannel(self.channel, self.strength * self.delay)
