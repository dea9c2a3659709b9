"""daq_b: family b's nominal measurement chain (not an effect: no case is labelled with it).

Family b's cases are acquired through a different DAQ from family a's: every channel passes a
2nd-order Butterworth anti-alias filter at 300 Hz before it is sampled, and the amplifiers add
a little noise of their own on top of the sensors' (:data:`brake_hil.physics.measurement.SENSORS`).
:func:`~brake_hil.virtual_rig.cases.make_case` installs :class:`MeasurementChainB` on every
family-b case through the host's acquisition port, after the effects' laws; the label records
it apart from the effects.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import ClassVar

import numpy as np

from brake_hil.physics.measurement import SENSORS
from brake_hil.types import FloatArray
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.family_b._filters import low_pass
from brake_hil.virtual_rig.laws import LtiPlant, TruthLaw

__all__ = ["DAQ_B", "AnalogueFrontEnd", "MeasurementChainB"]

DAQ_B = "daq_b"
"""The measurement chain's name (not a catalogue effect)."""

_CHANNEL_ORDER = ("p_i", "p_b", "F_k", "x_c", "p_a")


@dataclass(frozen=True)
class AnalogueFrontEnd(TruthLaw):
    """Every channel's anti-alias filter and amplifier noise (SI): the acquisition port."""

    cutoff: float  # rad/s, -3 dB frequency of the 2nd-order Butterworth
    noise_share: float  # -, amplifier noise rms over the sensor's own noise rms
    seed: int  # of the amplifier noise, one stream per channel

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        """``channel`` filtered, plus its amplifier's white noise (before the sensor's noise)."""
        filtered = low_pass("butterworth", self.cutoff, time, values)
        if self.noise_share <= 0.0:
            return filtered
        rng = np.random.default_rng([self.seed, _CHANNEL_ORDER.index(channel), 2])
        noise = rng.normal(0.0, self.noise_share * SENSORS[channel].noise_rms, filtered.shape)
        return np.asarray(filtered + noise, dtype=float)


@dataclass(frozen=True)
class MeasurementChainB(Effect):
    """Family b's DAQ: a 2nd-order Butterworth anti-alias filter on every channel, more noise.

    Every channel passes a 2nd-order Butterworth low-pass (default -3 dB at 300 Hz, a lag of
    0.75 ms at low frequency, the same on every channel) before it is sampled, and the
    amplifiers add white noise of ``noise_share`` times each sensor's own noise rms (total
    noise ``sqrt(1 + share^2)`` as large). Not physics of the rig, so no effect of the catalogue
    and never in a case's ``expected_effects``. Source: Tietze, Schenk, Electronic Circuits
    (Springer 2008), ch. 12.
    """

    strength: float = 1.0
    cutoff_frequency: float = 300.0
    noise_share: float = 0.5
    seed: int = 0

    name: ClassVar[str] = DAQ_B
    signature: ClassVar[str] = "every channel lags by 0.75 ms alike; noise 12 % higher"
    parameters = (
        STRENGTH,
        Parameter("cutoff_frequency", "1/s", 50.0, 500.0, "-3 dB frequency (Hz)"),
        Parameter("noise_share", "-", 0.0, 2.0, "amplifier noise over the sensor's"),
        Parameter("seed", "-", 0.0, 2.0**63, "seed of the amplifier noise"),
    )
    diagnosis_model = "the nominal measurement chain of family b (nothing to fit)"

    def law(self, plant: LtiPlant) -> AnalogueFrontEnd:
        """The front end (the same on every rig; ``strength`` 0 removes it)."""
        del plant
        return AnalogueFrontEnd(
            cutoff=2.0 * math.pi * self.cutoff_frequency,
            noise_share=self.noise_share,
            seed=int(self.seed),
        )
