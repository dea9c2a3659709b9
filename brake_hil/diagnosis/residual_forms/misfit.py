"""What the baseline's misfit of one channel looks like (:class:`ChannelMisfit`).

Static or rate-dependent, symmetric or not between apply and release, changing with the
pressure level or not, drifting in time or not; the thresholds of those flags.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from brake_hil.diagnosis.residual_forms.base import ChannelSpans
from brake_hil.types import FloatArray

__all__ = [
    "ASYMMETRY_LIMIT",
    "DRIFT_SHARE",
    "DRIFT_SIZE",
    "LEVEL_VARIATION",
    "RATE_SHARE",
    "STATIC_SHARE",
    "ChannelMisfit",
    "characterise",
]

STATIC_SHARE = 0.5
"""The misfit is static when a static cubic map of the prediction explains this share of it."""
RATE_SHARE = 0.3
"""It is rate-dependent when terms in ``dy_hat/dt`` explain this share more than the map."""
ASYMMETRY_LIMIT = 0.15
"""Apply and release differ when ``(E_apply - E_release) / (E_apply + E_release)`` exceeds
this in magnitude (``E`` the mean squared misfit at the same levels of the prediction)."""
LEVEL_VARIATION = 0.5
"""The misfit changes with the pressure level when the segments' mean misfit or gain error
(relative to each segment's swing) changes across them by this share of the misfit's typical
relative RMS, monotonically with the level."""
DRIFT_SHARE = 0.5
"""It drifts when a linear trend in time explains this share of the within-segment variance of
its cycle means ..."""
DRIFT_SIZE = 0.2
"""... and that trend's change over a segment is this share of the misfit's RMS."""


@dataclass(frozen=True)
class ChannelMisfit:
    """What the baseline's misfit of one channel looks like (fractions of its energy).

    ``static_fraction``: share of the misfit's energy (sum of squares) a cubic map of the
    prediction explains; ``rate_fraction``: the share terms in ``dy_hat/dt`` and its sign
    explain on top of it. ``asymmetry``: ``(E_apply - E_release) / (E_apply + E_release)`` at
    the same levels of the prediction (positive: larger while the prediction rises).
    Per segment, the mean misfit over the segment's swing (signed as the channel) and the gain
    error (``dy/dy_hat - 1``): ``level_variation`` is the change across the segments of
    whichever changes more (in misfit units) over the misfit's typical RMS relative to the
    swing, ``level_trend`` its Spearman correlation with the segment's mean pressure, positive
    when the measured channel grows relative to the prediction as the level rises. The
    calibration centres a misfit that grows with the level (it changes sign across the
    segments), so the trend, not the size at each level, says whether it grows.
    ``segment_misfit``: RMS misfit over each segment's peak-to-peak, lowest pressure first.
    ``drift_fraction``: share of the within-segment variance of the cycle means a linear trend
    in time explains;
    ``drift_size``: that trend's largest change over a segment over the misfit's RMS.
    """

    channel: str
    share: float  # of the baseline's held-out error (normalised), over channels
    held_out_rms: float  # the baseline's, over the channel's peak-to-peak
    static_fraction: float
    rate_fraction: float
    asymmetry: float
    level_variation: float
    level_trend: float
    segment_misfit: tuple[float, ...]
    drift_fraction: float
    drift_size: float

    @property
    def static(self) -> bool:
        """A static map of the prediction explains most of the misfit."""
        return self.static_fraction >= STATIC_SHARE and self.static_fraction > self.rate_fraction

    @property
    def dynamic(self) -> bool:
        """The misfit depends on the prediction's rate more than on its value."""
        return self.rate_fraction >= RATE_SHARE and self.rate_fraction > self.static_fraction

    @property
    def symmetric(self) -> bool:
        """Apply and release carry the same misfit at the same levels."""
        return abs(self.asymmetry) <= ASYMMETRY_LIMIT

    @property
    def level_dependent(self) -> bool:
        """The misfit changes, monotonically, with the pressure level."""
        return self.level_variation >= LEVEL_VARIATION and abs(self.level_trend) >= 0.9

    @property
    def grows_with_pressure(self) -> bool:
        """The measured channel grows relative to the prediction as the level rises."""
        return self.level_dependent and self.level_trend > 0

    @property
    def drifts(self) -> bool:
        """The misfit's cycle means follow a trend in time within the segments."""
        return self.drift_fraction >= DRIFT_SHARE and self.drift_size >= DRIFT_SIZE

    def as_dict(self) -> dict[str, object]:
        """Plain JSON, flags included."""
        return {
            "share": round(self.share, 4),
            "held_out_rms": self.held_out_rms,
            "static_fraction": round(self.static_fraction, 4),
            "rate_fraction": round(self.rate_fraction, 4),
            "asymmetry": round(self.asymmetry, 4),
            "level_variation": round(self.level_variation, 4),
            "level_trend": round(self.level_trend, 4),
            "segment_misfit": [round(v, 5) for v in self.segment_misfit],
            "drift_fraction": round(self.drift_fraction, 4),
            "drift_size": round(self.drift_size, 4),
            "static": self.static,
            "dynamic": self.dynamic,
            "symmetric": self.symmetric,
            "level_dependent": self.level_dependent,
            "grows_with_pressure": self.grows_with_pressure,
            "drifts": self.drifts,
        }


def _explained(design: FloatArray, target: FloatArray, total: float) -> float:
    """Share of ``total`` (sum of squares of ``target``) a least-squares fit explains."""
    coefficients = np.linalg.lstsq(design, target, rcond=None)[0]
    return float(1.0 - np.sum((target - design @ coefficients) ** 2) / total)


def _spearman(values: Sequence[float], levels: Sequence[float]) -> float:
    """Rank correlation of ``values`` with ``levels`` (0 for fewer than two)."""
    if len(values) < 2 or float(np.ptp(values)) == 0.0:
        return 0.0
    a = np.argsort(np.argsort(values)).astype(float)
    b = np.argsort(np.argsort(levels)).astype(float)
    return float(np.corrcoef(a, b)[0, 1])


def characterise(
    channel: str, data: ChannelSpans, pressures: Mapping[int, float], share: float, nrmse: float
) -> ChannelMisfit:
    """Describe one channel's misfit over all its windows (see :class:`ChannelMisfit`).

    Args:
        channel: the channel's name.
        data: the channel over every window, normalised.
        pressures: each segment's mean master-cylinder pressure (Pa).
        share: the channel's share of the baseline's held-out error.
        nrmse: the baseline's held-out RMS of the channel, over its peak-to-peak.
    """
    u = data.baseline
    r = data.target - u
    rate = np.concatenate([np.gradient(p, data.sample_time) for p in data.predicted])
    centred = (u - u.mean()) / max(float(u.std()), 1e-12)
    static_fraction, rate_fraction = _static_and_rate(centred, rate, r)
    segments = sorted(set(data.segment), key=lambda s: pressures[s])
    level_variation, level_trend, misfits = _level_dependence(data, segments, pressures, r)
    drift_fraction, drift_size = _drift(data, segments, r)
    return ChannelMisfit(
        channel=channel,
        share=share,
        held_out_rms=nrmse,
        static_fraction=static_fraction,
        rate_fraction=rate_fraction,
        asymmetry=_asymmetry(centred, rate, r),
        level_variation=level_variation,
        level_trend=level_trend,
        segment_misfit=tuple(misfits),
        drift_fraction=drift_fraction,
        drift_size=drift_size,
    )


def _static_and_rate(centred: FloatArray, rate: FloatArray, r: FloatArray) -> tuple[float, float]:
    """Shares of the misfit ``r`` a cubic map explains, and terms in the rate on top of it."""
    total = max(float(np.sum(r**2)), 1e-300)
    speed = rate / max(float(np.sqrt(np.mean(rate**2))), 1e-12)
    sign = np.sign(rate)
    static_design = np.column_stack([np.ones_like(centred), centred, centred**2, centred**3])
    rate_design = np.column_stack([speed, speed * centred, sign, sign * centred])
    static_fraction = _explained(static_design, r, total)
    rate_fraction = _explained(np.hstack([static_design, rate_design]), r, total) - static_fraction
    return static_fraction, rate_fraction


def _asymmetry(centred: FloatArray, rate: FloatArray, r: FloatArray) -> float:
    """Apply against release at the same levels of the prediction (see ChannelMisfit)."""
    edges = np.quantile(centred, np.linspace(0.0, 1.0, 11)[1:-1])
    bins = np.digitize(centred, edges)
    apply_energy = release_energy = 0.0
    for b in range(10):
        rising = r[(bins == b) & (rate > 0)]
        falling = r[(bins == b) & (rate < 0)]
        if rising.size >= 5 and falling.size >= 5:
            apply_energy += float(np.mean(rising**2))
            release_energy += float(np.mean(falling**2))
    return (apply_energy - release_energy) / max(apply_energy + release_energy, 1e-300)


def _level_dependence(
    data: ChannelSpans, segments: list[int], pressures: Mapping[int, float], r: FloatArray
) -> tuple[float, float, list[float]]:
    """``level_variation``, ``level_trend`` and each segment's RMS misfit (see ChannelMisfit).

    Each segment's mean misfit and gain error, relative to its own swing.
    """
    u = data.baseline
    owner = np.repeat(np.array(data.segment), [p.size for p in data.predicted])
    alphas, betas, misfits, spread = [], [], [], []
    for s in segments:
        inside = owner == s
        width = max(float(np.ptp(u[inside])), 1e-12)
        deviation = u[inside] - u[inside].mean()
        betas.append(
            float(np.dot(deviation, r[inside])) / max(float(np.dot(deviation, deviation)), 1e-300)
        )
        alphas.append(float(r[inside].mean()) / width * float(np.sign(u[inside].mean())))
        misfits.append(float(np.sqrt(np.mean(r[inside] ** 2))) / width)
        spread.append(float(np.sqrt(np.mean(deviation**2))) / width)
    # Each coefficient's change across the levels in the misfit's units (a gain error beta
    # moves the misfit by beta times the swing's RMS).
    change_alpha = float(np.ptp(alphas))
    change_beta = float(np.ptp(betas)) * float(np.mean(spread))
    trend_of = alphas if change_alpha >= change_beta else betas
    typical = max(float(np.sqrt(np.mean(np.square(misfits)))), 1e-300)
    level_variation = max(change_alpha, change_beta) / typical if len(segments) > 1 else 0.0
    level_trend = _spearman(trend_of, [pressures[s] for s in segments])
    return level_variation, level_trend, misfits


def _drift(data: ChannelSpans, segments: list[int], r: FloatArray) -> tuple[float, float]:
    """``drift_fraction`` and ``drift_size``: the cycle means' trend in time within segments."""
    m = data.period_samples
    explained = within = 0.0
    largest_change = 0.0
    for s in segments:
        means, times = [], []
        for p, y, t, seg in zip(data.predicted, data.measured, data.time, data.segment):
            if seg != s:
                continue
            cycles = p.size // m
            if cycles:
                residual = (y - p)[: cycles * m].reshape(cycles, m)
                means.extend(residual.mean(axis=1).tolist())
                times.extend(t[: cycles * m].reshape(cycles, m).mean(axis=1).tolist())
        if len(means) < 3:
            continue
        c = np.array(means) - np.mean(means)
        tc = np.array(times) - np.mean(times)
        slope = float(np.dot(tc, c) / max(float(np.dot(tc, tc)), 1e-300))
        explained += slope**2 * float(np.dot(tc, tc))
        within += float(np.dot(c, c))
        largest_change = max(largest_change, abs(slope) * float(np.ptp(times)))
    drift_fraction = explained / within if within > 0 else 0.0
    drift_size = largest_change / max(float(np.sqrt(np.mean(r**2))), 1e-300)
    return drift_fraction, drift_size
