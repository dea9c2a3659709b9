"""What the segments that are not steady pulsing show of the calibrated baseline's misfit.

* a sweep: per frequency band, each channel's gain and time lag measured against the
  baseline's (:func:`segment_metrics.sweep_response`). A fixed delay (a late ``p_i`` or a
  late channel) keeps the gain and the same time lag at every band; a compliance in the line
  (a swelling hose) lowers the bore pressure's gain as the frequency grows;
* a slow ramp: the static map's slope (output against ``p_i``) and its kink, the stick
  region (the ``p_i`` the output waits before it moves), against the baseline's; with a
  rise and a fall, the loop's width: flat edges where the seal holds the piston as ``p_i``
  turns, which no linear model makes;
* pulsing at another frequency, a modulated train: the RMS residual of each channel.

:func:`missing` names the excitation that would tell more than a recording holds.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np

from brake_hil.analysis import segment_metrics
from brake_hil.analysis.segmentation import Segment
from brake_hil.diagnosis.dataset import Dataset, Window
from brake_hil.errors import SignalError
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray

__all__ = ["SegmentSignals", "collect", "missing"]

EDGE_BANDS: Final = 3
"""A sweep's low (high) end is the mean of its first (last) this many bands."""
GAIN_FALL_PCT: Final = 2.0
"""The measured gain falling by more than this (percentage points of the model's) from the
sweep's low end to its high end is a compliance's or a lag's signature."""
FIXED_LAG_MS: Final = 0.5
"""A time lag changing by less than this (ms) across the sweep is fixed (a delay)."""
LOOP_SHARE: Final = 0.01
"""A loop narrower than this share of the channel's range is none."""
SEAL_LOOP_RATIO: Final = 3.0
"""The seal's outputs' (F_k, x_c) loop this many times wider than the bore pressure's: the
hysteresis is in the seal; a lag of the line would widen p_b's loop as much."""
SWEEP_ADVICE: Final = (
    "a 5-25 Hz sweep would tell a hose from a late p_i (a compliance lowers the bore "
    "pressure's gain as the frequency grows, a delay keeps it)"
)
RAMP_ADVICE: Final = (
    "a slow ramp up and back down (a few seconds each) would show the seal's stick region "
    "and its loop"
)
LEVELS_ADVICE: Final = (
    "pulsing at three pressures would tell a seal whose stiffness falls with the amplitude "
    "(stick-slip) from air whose compliance falls with the pressure"
)


@dataclass(frozen=True)
class SegmentSignals:
    """Measured and baseline-predicted signals over one segment's window."""

    window: Window
    time: FloatArray
    pressure: FloatArray
    measured: dict[str, FloatArray]
    predicted: dict[str, FloatArray]


def collect(
    dataset: Dataset, parts: Sequence[SegmentSignals]
) -> tuple[dict[str, float], list[str]]:
    """Numbers and sentences of the segments in ``parts`` (none steady pulsing)."""
    values: dict[str, float] = {}
    findings: list[str] = []
    scale = dataset.scale()
    for part in parts:
        segment = _segment(dataset, part)
        if part.window.kind == "sweep" and segment is not None:
            _sweep(part, segment, values, findings)
        elif part.window.kind == "ramp":
            _ramp(part, scale, values, findings)
        else:
            residual = {
                k: float(
                    np.sqrt(np.mean(((part.predicted[k] - part.measured[k]) / scale[k]) ** 2))
                )
                for k in OUTPUT_CHANNELS
            }
            findings.append(
                f"{_name(part)}: RMS residual "
                + ", ".join(f"{k} {100 * v:.2f} %" for k, v in residual.items())
            )
    ramps = [p for p in parts if p.window.kind == "ramp"]
    for rise, fall in zip(ramps, ramps[1:]):
        if _direction(rise) > 0 > _direction(fall):
            _loop(rise, fall, scale, values, findings)
    advice = missing(dataset)
    if advice:
        findings.append("what this recording cannot show: " + "; ".join(advice))
    return values, findings


def missing(dataset: Dataset) -> list[str]:
    """The excitations that would tell more than ``dataset`` holds, in words."""
    windows = dataset.segments
    kinds = {w.kind for w in windows}
    frequencies = {round(1.0 / w.period, 1) for w in windows if w.period > 0.0}
    advice = []
    if "sweep" not in kinds and len(frequencies) < 2:
        advice.append(SWEEP_ADVICE)
    ramps = [w for w in windows if w.kind == "ramp"]
    if len(ramps) < 2:
        advice.append(RAMP_ADVICE)
    levels = [w.mean_pressure for w in windows if w.kind in ("steady", "pulsing", "sweep")]
    if len(levels) < 2 or max(levels) < 1.3 * min(levels):
        advice.append(LEVELS_ADVICE)
    return advice


def _segment(dataset: Dataset, part: SegmentSignals) -> Segment | None:
    """The recording's segment that holds ``part``'s window."""
    window = part.window
    for segment in dataset.found:
        if segment.t_start <= window.start + 1e-6 and window.end <= segment.t_end + 1e-6:
            return segment
    return None


def _name(part: SegmentSignals) -> str:
    """``kind start-end s``."""
    return f"{part.window.kind} {part.window.start:.1f}-{part.window.end:.1f} s"


def _sweep(
    part: SegmentSignals, segment: Segment, values: dict[str, float], findings: list[str]
) -> None:
    """Gain and time lag per band, low end against high end, and what they point to."""
    ends: dict[str, tuple[float, float, float, float]] = {}
    low_hz = high_hz = 0.0
    for key in OUTPUT_CHANNELS:
        try:
            points = segment_metrics.sweep_response(
                part.time, part.pressure, part.predicted[key], part.measured[key], segment
            )
        except SignalError:
            return
        # measured gain in % of the model's; the measured channel's time lag behind it (ms)
        gain = np.array([1e4 / p["gain_ratio_pct"] for p in points])
        lag = np.array([p["phase_error_deg"] / 360.0 / p["frequency_hz"] * 1e3 for p in points])
        edge = min(EDGE_BANDS, max(len(points) // 2, 1))
        ends[key] = (
            float(np.mean(gain[:edge])),
            float(np.mean(gain[-edge:])),
            float(np.mean(lag[:edge])),
            float(np.mean(lag[-edge:])),
        )
        low_hz = float(np.mean([p["frequency_hz"] for p in points[:edge]]))
        high_hz = float(np.mean([p["frequency_hz"] for p in points[-edge:]]))
        for name, value in zip(
            ("gain_low_pct", "gain_high_pct", "lag_low_ms", "lag_high_ms"), ends[key]
        ):
            values[f"sweep_{name}_{key}"] = value
    findings.append(
        f"{_name(part)}, measured against the baseline at {low_hz:.0f} and {high_hz:.0f} Hz: "
        + "; ".join(
            f"{k} gain {g0:.1f} % then {g1:.1f} %, behind by {l0:+.2f} then {l1:+.2f} ms"
            for k, (g0, g1, l0, l1) in ends.items()
        )
    )
    findings.append(_sweep_reading(ends))
    seal = [k for k in ("F_k", "x_c") if abs(ends[k][1] - ends[k][0]) > GAIN_FALL_PCT]
    if seal:
        findings.append(
            f"{' and '.join(seal)} gain changes across the band ("
            + ", ".join(f"{k} {ends[k][0]:.1f} % to {ends[k][1]:.1f} %" for k in seal)
            + "): the seal's stiffness and damping are not the LTI model's at every "
            "frequency (characterize gives k_eh and c_eh per band)"
        )


def _sweep_reading(ends: dict[str, tuple[float, float, float, float]]) -> str:
    """What the sweep's ends point to, in words."""
    g0, g1, l0, l1 = ends["p_b"]
    lags = [v[2:] for v in ends.values()]
    fixed = all(abs(b - a) < FIXED_LAG_MS for a, b in lags)
    late = min(min(a, b) for a, b in lags) > FIXED_LAG_MS
    if g0 - g1 > GAIN_FALL_PCT:
        return (
            f"the bore pressure's gain falls from {g0:.1f} % to {g1:.1f} % of the model's as "
            "the frequency grows: a compliance or a restriction in the line (a hose), not a "
            "fixed delay"
        )
    if fixed and late:
        return (
            "every channel is late by the same time at every band, the gain unchanged: a fixed "
            "delay (a late p_i), not a compliance"
        )
    if fixed:
        return "no lag that grows with the frequency: neither a delay nor a compliance of the line"
    return (
        f"the bore pressure's lag moves from {l0:+.2f} to {l1:+.2f} ms across the sweep with its "
        f"gain at {g0:.1f}-{g1:.1f} %"
    )


def _direction(part: SegmentSignals) -> float:
    """+1 for a rising ramp, -1 for a falling one."""
    return float(np.sign(part.pressure[-1] - part.pressure[0]))


def _ramp(
    part: SegmentSignals, scale: dict[str, float], values: dict[str, float], findings: list[str]
) -> None:
    """The static map's slope and stick region, measured against the baseline."""
    words = []
    rising = "rise" if _direction(part) > 0 else "fall"
    segment = Segment("ramp", part.window.start, part.window.end, {"direction": rising})
    for key in OUTPUT_CHANNELS:
        window = (part.window.start, part.window.end)
        m = segment_metrics.score(
            segment,
            window,
            part.time,
            part.pressure,
            part.predicted[key],
            part.measured[key],
            scale[key],
        )
        ratio = 1e4 / float(m["map_gain_ratio_pct"])  # type: ignore[arg-type]
        stick = float(m["stick_measured_pa"]), float(m["stick_model_pa"])  # type: ignore[arg-type]
        values[f"ramp_{rising}_slope_pct_{key}"] = ratio
        values[f"ramp_{rising}_stick_measured_pa_{key}"] = stick[0]
        values[f"ramp_{rising}_stick_model_pa_{key}"] = stick[1]
        words.append(
            f"{key} slope {ratio:.1f} % of the model's, waits {stick[0] / 1e6:.2f} MPa of p_i "
            f"before it moves (model {stick[1] / 1e6:.2f} MPa)"
        )
    findings.append(
        f"{_name(part)} ({rising}), static map against the baseline: " + "; ".join(words)
    )


def _loop(
    rise: SegmentSignals,
    fall: SegmentSignals,
    scale: dict[str, float],
    values: dict[str, float],
    findings: list[str],
) -> None:
    """The loop between a rise and a fall: measured width against the baseline's."""
    words = []
    measured: dict[str, float] = {}
    model: dict[str, float] = {}
    for key in OUTPUT_CHANNELS:
        measured[key], model[key] = (
            segment_metrics.hysteresis((rise.pressure, y_rise), (fall.pressure, y_fall))
            / max(scale[key], 1e-30)
            for y_rise, y_fall in (
                (rise.measured[key], fall.measured[key]),
                (rise.predicted[key], fall.predicted[key]),
            )
        )
        values[f"loop_width_measured_pct_{key}"] = 100.0 * measured[key]
        values[f"loop_width_model_pct_{key}"] = 100.0 * model[key]
        words.append(f"{key} {100 * measured[key]:.2f} % (model {100 * model[key]:.2f} %)")
    seal = [
        k
        for k in ("F_k", "x_c")
        if measured[k] > LOOP_SHARE and measured[k] > SEAL_LOOP_RATIO * measured["p_b"]
    ]
    reading = ": no loop the linear model does not make"
    if seal:
        reading = (
            f": {' and '.join(seal)} loop {SEAL_LOOP_RATIO:g} times wider than p_b's: the "
            "hysteresis is in the seal (stick and slip, flat edges where it holds the piston "
            "as p_i turns), not a lag of the line"
        )
        if model["p_b"] > max(2.0 * measured["p_b"], LOOP_SHARE):
            reading += (
                f"; the baseline makes it by a lag that widens p_b's loop to "
                f"{100 * model['p_b']:.2f} %, which the measurement does not have"
            )
    findings.append(
        "loop between the rise and the fall (mean width over p_i, % of each channel's range): "
        + ", ".join(words)
        + reading
    )
