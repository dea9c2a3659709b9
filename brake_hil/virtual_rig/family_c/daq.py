"""Family c's measurement chain: anti-alias filter, sample-clock skew, hum and drift per channel.

Not an effect of the library (it is never labelled as one): every family-c case is acquired
through it, on top of the seed's white noise and 16-bit quantisation
(:func:`brake_hil.virtual_rig.simulator.acquire`). It is an
:class:`~brake_hil.virtual_rig.effects.base.Effect` only so the host installs it like one.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import ClassVar

import numpy as np
from scipy.signal import bessel, lfilter, lfilter_zi

from brake_hil.physics.catalogue import EffectEntry, Quantity
from brake_hil.physics.measurement import SENSORS
from brake_hil.types import FloatArray
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.laws import LtiPlant, TruthLaw

__all__ = ["DAQ_C", "MeasurementChainC"]

CUTOFF_HZ = 300.0
"""The anti-alias filter's corner: a 2nd-order Bessel, the same on every channel."""
MAINS_HZ = 50.0
CHANNELS = ("p_i", "p_b", "F_k", "x_c", "p_a")

DAQ_C = EffectEntry(
    name="daq_c",
    title="family c's measurement chain",
    physics=(
        "Each channel passes a 2nd-order Bessel anti-alias filter; the sample-and-hold reads "
        "the channels one after another (a few microseconds apart) on a clock a few ppm off; "
        "each channel picks up mains hum and a slow zero drift beside its white noise."
    ),
    source="acquisition chain (not in the paper)",
    signature="none meant: a DAQ within a lab's specification",
    channels=("p_b", "F_k", "x_c"),
    quantities=(Quantity("seed", "-", "seed of the chain's hum phases and drifts"),),
)


@dataclass(frozen=True)
class _Chain(TruthLaw):
    seed: int
    cutoff: float  # Hz
    clock_ppm: float  # the sample clock's rate error, ppm
    slot: float  # s, the multiplexer's time between neighbouring channels

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        if values.size < 8:
            return values
        index = CHANNELS.index(channel) if channel in CHANNELS else 0
        rng = np.random.default_rng([self.seed, 3, index])
        step = float(np.median(np.diff(time)))
        # the clock runs fast by clock_ppm and each channel is sampled slot * index late
        when = time[0] + (time - time[0]) * (1.0 + 1e-6 * self.clock_ppm) - index * self.slot
        read = np.interp(when, time, values)
        b, a = bessel(2, self.cutoff * 2.0 * step, norm="delay")
        filtered, _ = lfilter(b, a, read, zi=lfilter_zi(b, a) * read[0])
        noise = SENSORS[channel].noise_rms if channel in SENSORS else 0.0
        hum = 0.4 * noise * np.sin(2.0 * math.pi * MAINS_HZ * time + rng.uniform(0, 2 * math.pi))
        walk = np.cumsum(rng.normal(0.0, 1.0, values.size))
        drift = 1.5 * noise * (walk - walk[0]) / math.sqrt(values.size)
        return np.asarray(filtered + hum + drift, dtype=float)


@dataclass(frozen=True)
class MeasurementChainC(Effect):
    """Family c's DAQ (see the module docstring): Bessel anti-alias, skewed clock, hum, drift."""

    entry: ClassVar[EffectEntry] = DAQ_C
    seed: int = 0
    clock_ppm: float = 30.0

    parameters: ClassVar[tuple[Parameter, ...]] = (
        STRENGTH,
        Parameter("seed", "-", 0, 2**31 - 1, "seed of the hum phases and the drifts"),
        Parameter("clock_ppm", "-", -200.0, 200.0, "the sample clock's rate error, ppm"),
    )
    diagnosis_model: ClassVar[str] = "none: a measurement chain, not an effect"

    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""
        del plant
        return _Chain(self.seed, CUTOFF_HZ, self.clock_ppm, 5.0e-6)
