"""sensor_delay: one measured channel lags the others (acquisition skew)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import lfilter

from brake_hil.physics import catalogue
from brake_hil.types import FloatArray
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.effects.registry import register_effect
from brake_hil.virtual_rig.laws import LtiPlant, TruthLaw

CHANNELS = ("p_i", "p_b", "F_k", "x_c")


@dataclass(frozen=True)
class ChannelSkew(TruthLaw):
    """A channel's acquisition path: a fractional delay then a first-order low-pass (SI).

    The host's acquisition port.
    """

    channel: str  # p_i, p_b, F_k or x_c
    delay: float  # s, pure (fractional) delay
    time_constant: float  # s, of the anti-alias low-pass

    @property
    def total_delay(self) -> float:
        """Low-frequency lag (s): delay plus the low-pass's group delay at DC."""
        return self.delay + self.time_constant

    def apply(self, time: FloatArray, values: FloatArray) -> FloatArray:
        """The channel as acquired: ``values`` (sampled at ``time``, s) delayed and filtered.

        The delay is read off a cubic spline through the samples (the first value is held
        before the start); the low-pass is discretised exactly for an input linear between
        samples, so its lag at low frequency is exactly ``time_constant``.
        """
        delayed = values
        if self.delay > 0.0:
            spline = CubicSpline(time, values)
            shifted = time - self.delay
            delayed = np.where(shifted >= time[0], spline(np.maximum(shifted, time[0])), values[0])
        if self.time_constant <= 0.0:
            return np.asarray(delayed, dtype=float)
        step = float(np.median(np.diff(time)))
        decay = float(np.exp(-step / self.time_constant))
        current = 1.0 - self.time_constant / step * (1.0 - decay)
        previous = self.time_constant / step * (1.0 - decay) - decay
        filtered, _ = lfilter(
            [current, previous], [1.0, -decay], delayed, zi=[delayed[0] * (1.0 - current)]
        )
        return np.asarray(filtered, dtype=float)

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        """The skewed channel through :meth:`apply`; the others unchanged."""
        return self.apply(time, values) if channel == self.channel else values


@register_effect
@dataclass(frozen=True)
class SensorDelay(Effect):
    """Sensor delay: one channel reaches the acquisition later than the others.

    Causes: a sensor's own conditioning electronics, a second DAQ card, a transport delay. Its
    samples are stamped too early and it appears to lag. Phase offsets (``tau / T``, seed
    Tables 4-5) of a few per cent are a few milliseconds at 5 Hz, so a skew of that size reads as a
    model error. The simulator delays the chosen channel's true signal by a fractional delay
    (cubic-spline interpolation between samples; Laakso, Valimaki, Karjalainen, Laine, "Splitting
    the unit delay", IEEE Signal Processing Magazine 13(1), 1996) and then passes it through a
    first-order anti-alias low-pass; together they lag the channel by ``strength * delay`` at low
    frequency, ``filter_share`` of it from the low-pass. Noise and quantisation follow.
    Source: seed Tables 4-5 (tau / T); Laakso et al. (1996).
    """

    strength: float = 1.0
    channel: str = "x_c"
    delay: float = 4.0e-3
    filter_share: float = 0.25

    entry = catalogue.entry("sensor_delay")
    parameters = (
        STRENGTH,
        Parameter("channel", "channel", 0.0, 0.0, "the skewed channel", choices=CHANNELS),
        Parameter("delay", "s", 1.0e-4, 0.05, "total low-frequency lag at strength 1"),
        Parameter("filter_share", "-", 0.0, 0.9, "share of the lag from the low-pass"),
    )
    diagnosis_model = (
        "a pure time shift of one channel; the simulator adds a first-order low-pass, so the "
        "phase lag is not exactly linear in frequency and the amplitude falls slightly"
    )

    def law(self, plant: LtiPlant) -> ChannelSkew:
        """The acquisition path at this strength (the same on every rig)."""
        del plant
        lag = self.strength * self.delay
        return ChannelSkew(
            channel=self.channel,
            delay=lag * (1.0 - self.filter_share),
            time_constant=lag * self.filter_share,
        )
