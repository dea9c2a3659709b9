"""sensor_delay: a measured channel lags the others (acquisition skew)."""

from __future__ import annotations

import numpy as np

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
)
from brake_hil.diagnosis.engine import ChannelDelay
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.types import FloatArray

SKEW_THRESHOLD = 0.5e-3
"""Delay difference (s) that counts as acquisition skew."""


class SensorDelay(Candidate):
    """Sensor delay: each channel is acquired late by its own delay.

    Multiplexed DAQs, anti-alias filters and CAN gateways delay channels by different times;
    the seed's ``tau`` of a few per cent of 200 ms is a few milliseconds. Modelled as a pure
    delay of each measured output relative to ``p_i`` (a negative delay means ``p_i`` itself
    is acquired late).
    """

    entry = CATALOGUE["sensor_delay"]
    parameters = tuple(
        CandidateParameter(f"delay_{channel}", "s", -0.02, 0.02, 0.0)
        for channel in ("p_b", "F_k", "x_c")
    )

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Delay each output channel."""
        draft.add(ChannelDelay(theta[:, :3].copy()))

    def plausible(self, theta: FloatArray) -> bool:
        """Skew: one output lags the others by over 0.5 ms, or every output leads alike.

        Every output leading alike is the input ``p_i`` acquired late. A common lag of every
        output is the model's own phase error, not acquisition skew.
        """
        delays = np.asarray(theta[:3], dtype=float)
        spread = float(np.max(np.abs(delays - np.median(delays))))
        return spread > SKEW_THRESHOLD or float(np.max(delays)) < -SKEW_THRESHOLD

    def consistent(self, evidence: dict[str, float]) -> bool:
        """A channel lags by more than a millisecond."""
        return max(abs(evidence.get(f"lag_{c}_ms", 0.0)) for c in ("p_b", "F_k", "x_c")) > 1.0
