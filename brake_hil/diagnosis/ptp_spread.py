"""How far from 100 % a rig file's own tolerances let the LTI model's ptp ratios sit.

A regression baseline (``brake-hil regress --update``) is itself far off when the model's ptp
ratio of a channel is further from 100 % than any rig within the rig file's tolerances would
put it: its values are then not this rig's. The spread is the calibration's prior
(:func:`.calibration.prior`: every toleranced value carried into the calibrated multipliers,
with their correlations) pushed through the ptp ratio's sensitivity to each multiplier,
measured on the recording itself (finite differences of the paper's Table 4-5 ptp ratio,
:func:`~brake_hil.analysis.comparison.compare`, over its steady pulsing).
"""

from __future__ import annotations

import math

import numpy as np

from brake_hil.analysis.comparison import compare
from brake_hil.analysis.recording import Recording
from brake_hil.diagnosis.calibration import apply_multipliers, prior, uncertain_values
from brake_hil.physics.rig import Rig
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray

__all__ = ["STEP", "ptp_spread"]

STEP = 0.05
"""Log step of the finite differences: small against every tolerance (the tightest default,
10 %), large against the ptp ratio's rounding."""


def _ptp_ratios(recording: Recording, rig: Rig, multipliers: dict[str, float]) -> FloatArray:
    """Each channel's ptp ratio (%), the mean over the steady segments."""
    mean = float(np.mean(recording.master_cylinder_pressure))
    params = apply_multipliers(rig, mean, multipliers)
    segments = compare(recording, rig, params).segments
    return np.array(
        [np.mean([s.metrics[key].ptp_ratio_pct for s in segments]) for key in OUTPUT_CHANNELS]
    )


def ptp_spread(recording: Recording, rig: Rig) -> dict[str, float]:
    """One-sigma spread (percentage points) of each channel's ptp ratio the tolerances allow.

    Raises:
        SignalError: the recording holds no steady pulsing (nothing to compare over).
    """
    values = uncertain_values(rig)
    if not values:
        return dict.fromkeys(OUTPUT_CHANNELS, 0.0)
    covariance, _ = prior(rig, values)
    nominal = _ptp_ratios(recording, rig, {})
    columns = [
        (_ptp_ratios(recording, rig, {u.name: math.exp(STEP)}) - nominal) / STEP for u in values
    ]
    jacobian = np.array(columns).T  # channel x multiplier
    variance = np.einsum("ci,ij,cj->c", jacobian, covariance, jacobian)
    return {key: float(np.sqrt(max(v, 0.0))) for key, v in zip(OUTPUT_CHANNELS, variance)}
