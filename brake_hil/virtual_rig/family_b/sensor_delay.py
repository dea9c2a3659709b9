"""sensor_delay, family b: a whole-sample transport delay and a 2nd-order anti-alias filter."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from brake_hil.types import FloatArray
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.effects.sensor_delay import CHANNELS
from brake_hil.virtual_rig.family_b._filters import (
    FILTER_KINDS,
    dc_group_delay_factor,
    low_pass,
    transport_delay,
)
from brake_hil.virtual_rig.family_b.base import FamilyBEffect, register_effect_b
from brake_hil.virtual_rig.laws import LtiPlant, TruthLaw

__all__ = ["FilteredTransport", "SensorDelayB"]

_SHORTEST_FILTER_DELAY = 1.0e-4
"""Group delay (s) the filter keeps at least, however the lag is split (cut-off below 4 kHz)."""


@dataclass(frozen=True)
class FilteredTransport(TruthLaw):
    """A channel's acquisition path: whole-sample transport, then a 2nd-order low-pass (SI).

    The host's acquisition port.
    """

    channel: str  # p_i, p_b, F_k or x_c
    lag: float  # s, the whole path's lag at low frequency
    filter_share: float  # -, share of the lag the filter should take before rounding
    kind: str  # bessel or butterworth

    def split(self, sample_period: float) -> tuple[int, float]:
        """Transport delay in whole samples and the filter's group delay (s) that completes it."""
        samples = int(np.floor((1.0 - self.filter_share) * self.lag / sample_period))
        rest = self.lag - samples * sample_period
        if rest < _SHORTEST_FILTER_DELAY and samples > 0:
            samples -= 1
            rest += sample_period
        return samples, max(rest, _SHORTEST_FILTER_DELAY)

    def apply(self, time: FloatArray, values: FloatArray) -> FloatArray:
        """The channel as acquired: ``values`` (sampled at ``time``, s) delayed and filtered."""
        period = float(np.median(np.diff(time)))
        samples, filter_delay = self.split(period)
        cutoff = dc_group_delay_factor(self.kind) / filter_delay
        return low_pass(self.kind, cutoff, time, transport_delay(samples, values))

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        """The delayed channel through :meth:`apply`; the others unchanged."""
        return self.apply(time, values) if channel == self.channel else values


@register_effect_b
@dataclass(frozen=True)
class SensorDelayB(FamilyBEffect, effect="sensor_delay"):
    """Sensor delay (family b): one channel passes a frame buffer and a 2nd-order low-pass.

    A channel that reaches the acquisition through a CAN gateway or a second DAQ card is held for
    whole sample periods (a transport delay of ``k`` samples) and its conditioning amplifier
    low-passes it with a 2nd-order anti-alias filter, a Bessel (linear phase) or a Butterworth
    (flat gain) prototype (Tietze, Schenk, Electronic Circuits, Springer 2008, ch. 12); its
    samples are stamped too early and it lags. The simulator delays the chosen channel by
    ``floor((1 - share) L / T_s)`` whole samples and passes it through the filter, run
    exactly in continuous time on the signal read linearly between samples, with its cut-off
    set so that its group delay at DC makes up the rest of the lag ``L = strength * delay``.
    Unlike family a (a cubic-spline fractional delay and a first-order low-pass) the filter is
    2nd order (its phase lag bends above a few tens of Hz and, for a Butterworth, its gain peaks
    in group delay) and the pure part comes in whole samples. Noise and quantisation follow.
    Source: seed Tables 4-5 (tau / T); Tietze and Schenk (2008).
    """

    strength: float = 1.0
    channel: str = "x_c"
    kind: str = "bessel"
    delay: float = 4.0e-3
    filter_share: float = 0.5

    parameters = (
        STRENGTH,
        Parameter("channel", "channel", 0.0, 0.0, "the delayed channel", choices=CHANNELS),
        Parameter("kind", "-", 0.0, 0.0, "the filter's prototype", choices=FILTER_KINDS),
        Parameter("delay", "s", 1.0e-4, 0.05, "total low-frequency lag at strength 1"),
        Parameter("filter_share", "-", 0.05, 1.0, "share of the lag from the filter"),
    )
    diagnosis_model = (
        "a pure time shift of one channel; the simulator adds a 2nd-order anti-alias "
        "filter, so the phase lag is not linear in frequency and the amplitude falls"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> Effect:
        """Channel and prototype uniformly, lag 3-5 ms, filter share 0.3-0.7."""
        return cls(
            strength=strength,
            channel=str(rng.choice(CHANNELS)),
            kind=str(rng.choice(FILTER_KINDS)),
            delay=float(np.round(rng.uniform(3.0e-3, 5.0e-3), 5)),
            filter_share=float(np.round(rng.uniform(0.3, 0.7), 3)),
        )

    def law(self, plant: LtiPlant) -> FilteredTransport:
        """The acquisition path at this strength (the same on every rig)."""
        del plant
        return FilteredTransport(
            channel=self.channel,
            lag=self.strength * self.delay,
            filter_share=self.filter_share,
            kind=self.kind,
        )
