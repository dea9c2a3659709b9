"""sensor_delay: a measured channel lags the others (acquisition skew)."""

from __future__ import annotations

import numpy as np

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
    Rival,
)
from brake_hil.diagnosis.candidates.registry import register_candidate_class
from brake_hil.diagnosis.candidates.resonant_reading import ResonantReading
from brake_hil.diagnosis.engine import ChannelDelay
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.types import FloatArray

SKEW_THRESHOLD = 0.5e-3
"""Delay difference (s) that counts as acquisition skew."""
SEGMENT_SKEW_SHARE = 0.3
"""A skewed channel's skew may differ between the pressure segments by at most this share of
its largest: a delay is a time, the same at every amplitude, while a load cell's hysteresis
or a creeping hose read as a lag falls with amplitude, as a loop of fixed width does (evidence
in docs/diagnosis.md)."""
CHANNELS = ("p_b", "F_k", "x_c")
LATE_INPUT_SKEW_SHARE = 0.5
"""A skew under this share of a lead common to every output is a late ``p_i``'s filter passed
differently by each output (:meth:`SensorDelay.segments_disagree`)."""
LONGEST_DELAY = 0.02
"""s, the bound of each channel's delay either way."""


def _skews(theta: FloatArray) -> FloatArray:
    """Each channel's delay over the median of the three (s): its acquisition skew."""
    delays = np.asarray(theta[:3], dtype=float)
    return np.asarray(delays - np.median(delays), dtype=float)


@register_candidate_class
class SensorDelay(Candidate):
    """Sensor delay: each channel is acquired late by its own delay.

    Multiplexed DAQs, anti-alias filters and CAN gateways delay channels by different times;
    the paper's ``tau`` of a few per cent of 200 ms is a few milliseconds. Modelled as a pure
    delay of each measured output relative to ``p_i`` (a negative delay means ``p_i`` itself
    is acquired late).
    """

    entry = CATALOGUE["sensor_delay"]
    parameters = tuple(
        CandidateParameter(f"delay_{channel}", "s", -LONGEST_DELAY, LONGEST_DELAY, 0.0)
        for channel in CHANNELS
    )
    lookahead = LONGEST_DELAY  # a negative delay reads the run ahead

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Delay each output channel."""
        draft.add(ChannelDelay(theta[:, :3].copy()))

    def plausible(self, theta: FloatArray) -> bool:
        """Skew: one output lags the others by over 0.5 ms, or every output leads alike.

        Every output leading alike is the input ``p_i`` acquired late. A common lag of every
        output is the model's own phase error, not acquisition skew.
        """
        spread = float(np.max(np.abs(_skews(theta))))
        return spread > SKEW_THRESHOLD or float(np.max(theta[:3])) < -SKEW_THRESHOLD

    def segments_disagree(self, per_segment: FloatArray) -> str | None:
        """A skew that changes between the segments (rows).

        A channel's skew is its delay over each segment's median delay (the other outputs);
        the most skewed channel, when it exceeds ``SKEW_THRESHOLD`` on average, must hold its
        skew within ``SEGMENT_SKEW_SHARE`` of its largest. The others are not judged: beside
        a late channel the median is one of them, whose calibrated phase moves with the
        segment (a true late ``x_c`` of family b left ``F_k`` at -0.68, -0.56, -0.44 ms). Nor
        is the delay common to every output (a late ``p_i``): fitted per segment it trades
        with the calibration's own phase (a true late ``p_i`` came out 0.11, 0.84, 0.95 ms).
        Nor, when every output leads in every segment (a late ``p_i``), a skew under half that
        common lead: the outputs' own dynamics pass its filter differently (every output a few
        ms early, ``p_b`` some tenths of a ms less so).
        """
        delays = np.asarray(per_segment, dtype=float)[:, :3]
        if delays.shape[0] < 2:
            return None
        skews = delays - np.median(delays, axis=1, keepdims=True)
        lead = -np.max(delays, axis=1)  # the least every output leads by, segment by segment
        if np.all(lead > SKEW_THRESHOLD) and np.all(
            np.max(np.abs(skews), axis=1) < LATE_INPUT_SKEW_SHARE * lead
        ):
            return None  # a late p_i
        most = int(np.argmax(np.mean(np.abs(skews), axis=0)))
        skew = skews[:, most]
        if float(np.mean(np.abs(skew))) <= SKEW_THRESHOLD:
            return None  # not skewed
        if float(np.ptp(skew)) > SEGMENT_SKEW_SHARE * float(np.max(np.abs(skew))):
            shown = ", ".join(f"{1e3 * value:.2f}" for value in skew)
            return (
                f"the skew of {CHANNELS[most]} differs between the segments ({shown} ms, "
                f"segment by segment): a delay is the same at every amplitude; a loop of "
                f"fixed width read as a lag shrinks as the amplitude grows"
            )
        return None

    def rivals(self, theta: FloatArray) -> tuple[Rival, ...]:
        """The most skewed channel, when skewed, read through a mode of its own.

        A transducer behind a lightly damped tapping line lags at the pulsing's frequency as
        well, and amplifies it by ``1 / (1 - (f / f_n)^2)``; a delay plus a recalibrated
        plant mimics that gain only by bending the rig's values (a pressure tap at 36 Hz came
        out as ``p_b`` 3.2 ms late, ``F_k`` and ``x_c`` 1.3 and 0.8 ms early, the seal's
        damping doubled).
        """
        skews = np.abs(_skews(theta))
        most = int(np.argmax(skews))
        return (ResonantReading(CHANNELS[most]),) if skews[most] > SKEW_THRESHOLD else ()

    def not_alone(self, theta: FloatArray) -> str | None:
        """A skewed channel beside a common lag (or lead) of the other two outputs.

        One late channel moves that channel alone; a late ``p_i`` moves every output alike.
        Fitted delays that do both (one channel skewed over ``SKEW_THRESHOLD`` and the other
        two off zero by as much, alike) are two timing errors: a second late channel, or a
        lag the calibrated model cannot make (a hose's or air's) read as a common delay
        (:meth:`plausible`: a common lag is the model's own phase error).
        """
        delays = np.asarray(theta[:3], dtype=float)
        skews = _skews(theta)
        most = int(np.argmax(np.abs(skews)))
        if abs(skews[most]) <= SKEW_THRESHOLD:
            return None
        common = float(np.mean(np.delete(delays, most)))
        if abs(common) <= SKEW_THRESHOLD:
            return None
        return (
            f"its delays are a skew of {CHANNELS[most]} ({1e3 * skews[most]:+.2f} ms) and a "
            f"common {'lag' if common > 0 else 'lead'} of the other outputs "
            f"({1e3 * common:+.2f} ms): no one late channel does both; a second late channel, "
            "or a lag of the line the calibrated model lacks (a hose, air), is there too"
        )

    def consistent(self, evidence: dict[str, float]) -> bool:
        """A channel lags by more than a millisecond."""
        return max(abs(evidence.get(f"lag_{c}_ms", 0.0)) for c in CHANNELS) > 1.0
