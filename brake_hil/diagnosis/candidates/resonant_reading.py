"""resonant_reading: a channel read through a lightly damped mode (a rival, not an effect).

Not in the library and never named: no catalogue entry of interface.md describes it, so it is
not registered. The physics checks fit it, with the calibration refitted, as the rival of an
effect that only shifts a channel in time (``SensorDelay.rivals``): a transducer behind a
resonant tapping line lags at the pulsing's frequency too, but it also amplifies, and a
delay plus a recalibrated plant can mimic a few per cent of gain only by bending the rig's
values. When the channel reads at least as well through a mode damped under
``LIGHT_DAMPING``, the delay is a stand-in.
"""

from __future__ import annotations

from brake_hil.diagnosis.candidates.base import CandidateParameter, Context, Draft, Rival
from brake_hil.diagnosis.engine import ChannelReading
from brake_hil.physics.catalogue import EffectEntry, Quantity
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray

LIGHT_DAMPING = 0.4
"""A mode damped less than this is a resonance, not a filter: fitted in a delay's place,
resonant pressure tappings come out at damping ratios of 0.06-0.20, true delays at 0.55-0.88
(a delay's nearest mode is a Butterworth filter's, 0.71) (evidence in docs/diagnosis.md)."""

READING = EffectEntry(
    name="resonant_reading",
    title="a channel read through a lightly damped mode",
    physics=(
        "The transducer sits behind a fluid column or a soft mount: a mass on a spring between "
        "the quantity and the sensing element, so the reading follows it through "
        "w^2 / (s^2 + 2 zeta w s + w^2), amplified by 1 / (1 - (f / f_n)^2) below f_n and "
        "lagging by about 2 zeta / w."
    ),
    source=(
        "Bergh and Tijdeman, NLR-TR F.238 (1965); Doebelin, Measurement Systems (2004), "
        "tubing and volumes"
    ),
    signature="one channel larger and later than the model at the pulsing's frequency",
    channels=OUTPUT_CHANNELS,
    quantities=(
        Quantity("f_n", "1/s", "natural frequency of the reading"),
        Quantity("zeta", "-", "its damping ratio"),
    ),
)


class ResonantReading(Rival):
    """One output channel read through a second-order mode of its own (unit static gain)."""

    entry = READING
    told_apart = 1.0  # a delay must read the channel better than the mode does
    why = "a delay does not amplify, a resonant tapping line or mount does"
    unlike = "damped as a filter is, not a resonance"
    parameters = (
        CandidateParameter("reading_frequency", "Hz", 10.0, 300.0, 40.0, logarithmic=True),
        CandidateParameter("reading_damping_ratio", "-", 0.02, 1.5, 0.3, logarithmic=True),
    )

    def __init__(self, channel: str) -> None:
        self.channel = channel

    def holds(self, theta: FloatArray) -> bool:
        """A lightly damped mode (under ``LIGHT_DAMPING``): a resonance, not a filter."""
        return float(theta[1]) < LIGHT_DAMPING

    def in_words(self, theta: FloatArray) -> str:
        """``p_b read through a mode (35 Hz, damping ratio 0.10)``."""
        mode = f"{theta[0]:.0f} Hz, damping ratio {theta[1]:.2f}"
        return f"{self.channel} read through a mode ({mode})"

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Read the channel through the mode."""
        draft.add(
            ChannelReading(
                OUTPUT_CHANNELS.index(self.channel), theta[:, 0].copy(), theta[:, 1].copy()
            )
        )
