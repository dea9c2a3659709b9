"""The metric that fits each segment kind, prediction against measurement (ROS-free).

* pulsing: the paper's Tables 4-5 per cycle at the segment's own frequency
  (:func:`signals.cycle_metrics`);
* sweep: each channel's frequency response to ``p_i`` (:func:`sweep_response`), the
  model's gain and phase against the measurement's per frequency band, the worst band named;
* ramp: the static map (output against ``p_i``): its slope, and with a rise and a fall the
  hysteresis loop's width and the stick region (:func:`hysteresis`);
* step: 10-90 % rise time, overshoot and 2 % settling time (:func:`step_response`);
* hold: the held level; modulated: peak-to-peak, lag and NRMSE.

Every scored segment also has the NRMSE of the channel over it. Signals are the 30 Hz
low-passed ones, on one time base (s); the channel units are kept (Pa, N, m).
"""

from __future__ import annotations

import math
from typing import Final

import numpy as np

from brake_hil.analysis import signals
from brake_hil.analysis.cycles import sample_interval
from brake_hil.analysis.segmentation import Segment
from brake_hil.errors import SignalError
from brake_hil.types import FloatArray

__all__ = [
    "HEADLINE_METRICS",
    "METRIC_NAMES",
    "band_windows",
    "hysteresis",
    "lag_s",
    "score",
    "step_response",
    "sweep_response",
]

METRIC_NAMES: Final = {
    "pulsing": "cycles (Tables 4-5 at the segment's frequency)",
    "sweep": "frequency response (gain and phase to p_i per band)",
    "ramp": "static map (output against p_i) and hysteresis",
    "step": "step response (rise time, overshoot, settling)",
    "hold": "held level",
    "modulated": "peak-to-peak, lag and NRMSE",
}
"""The metric each scored kind gets, as the output names it (idle is not scored)."""
HEADLINE_METRICS: Final = {
    "pulsing": ("ptp_ratio_pct", "tau_over_T_pct", "nrmse"),
    "sweep": ("mean_gain_ratio_pct", "mean_phase_error_deg", "worst_error_pct", "nrmse"),
    "ramp": ("map_gain_ratio_pct", "stick_error_pct", "loop_width_error_pct", "nrmse"),
    "step": ("rise_time_ratio_pct", "overshoot_error_pct", "settling_error_s", "nrmse"),
    "hold": ("level_error_pct",),
    "modulated": ("ptp_ratio_pct", "tau_over_T_pct", "nrmse"),
}
"""Per scored kind, the metrics that hold model against measurement (a ramp's loop width
only after a rise): what ``regress`` checks and the live comparator logs."""

SETTLING_BAND: Final = 0.02
"""A step has settled once within this share of its change of its final level."""
STICK_SHARE: Final = 0.02
"""The stick region ends where the output has moved this share of its change."""


def _span(values: FloatArray) -> float:
    """Peak-to-peak, never zero (for ratios)."""
    return max(float(np.ptp(values)), float(np.finfo(float).tiny))


def lag_s(
    time: FloatArray, predicted: FloatArray, measured: FloatArray, part: slice, most_s: float
) -> float:
    """Delay (s) of the measurement behind the prediction over the samples ``part``.

    The prediction (over the whole recording, so that a shift brings in its own samples)
    is shifted by each whole-sample lag within ``+- most_s`` and fitted to the measurement
    with a gain and an offset; the lag of least residual is refined between samples by a
    parabola. Positive when the prediction comes first, as the paper's ``tau``.
    """
    step = sample_interval(time)
    most = max(1, int(most_s / step))
    t = time[part]
    target = measured[part] - np.mean(measured[part])
    residuals = []
    for k in range(-most, most + 1):
        shifted = np.interp(t - k * step, time, predicted)
        shifted = shifted - np.mean(shifted)
        scale = float(shifted @ shifted)
        fit = float(target @ shifted) / scale if scale > 0 else 0.0
        residuals.append(float(np.sum((target - fit * shifted) ** 2)))
    values = np.asarray(residuals)
    k = int(np.argmin(values))
    shift = 0.0
    if 0 < k < values.size - 1:
        left, mid, right = values[k - 1], values[k], values[k + 1]
        curve = left - 2.0 * mid + right
        shift = 0.5 * (left - right) / curve if curve > 0 else 0.0
    return float((k - most + shift) * step)


# --------------------------------------------------------------------------- sweeps


def _sweep_time(segment: Segment, frequency: float) -> float:
    """When a sweep segment passes ``frequency`` (Hz), by its law (s)."""
    d = segment.descriptors
    f0, f1 = float(d["f0_hz"]), float(d["f1_hz"])
    share = (
        math.log(frequency / f0) / math.log(f1 / f0)
        if d["law"] == "log"
        else (frequency - f0) / (f1 - f0)
    )
    return segment.t_start + share * segment.duration


def band_windows(segment: Segment, cycles: float = 4.0) -> list[tuple[float, float, float]]:
    """Frequency bands of a sweep: ``(centre Hz, t_start s, t_end s)`` each.

    Bands 1 Hz wide on a linear sweep, a tenth of a decade on a log one, widened to hold at
    least ``cycles`` cycles; the half-band at each end of the sweep is left out.
    """
    d = segment.descriptors
    f0, f1 = sorted((float(d["f0_hz"]), float(d["f1_hz"])))
    if d["law"] == "log":
        centres = np.exp(np.arange(math.log(f0) + 0.115, math.log(f1) - 0.115 + 1e-9, 0.23))
    else:
        centres = np.arange(math.ceil(f0 + 0.5), math.floor(f1 - 0.5) + 1e-9, 1.0)
    bands = []
    for centre in centres:
        half = 0.5 if d["law"] != "log" else centre * 0.115
        ends = sorted(_sweep_time(segment, f) for f in (centre - half, centre + half))
        middle, width = 0.5 * sum(ends), max(ends[1] - ends[0], cycles / centre)
        start, end = (
            max(middle - width / 2, segment.t_start),
            min(middle + width / 2, segment.t_end),
        )
        bands.append((float(centre), start, end))
    return bands


def instantaneous_phase(time: FloatArray, pressure: FloatArray, segment: Segment) -> FloatArray:
    """Phase (rad) of ``p_i`` over a segment, from its analytic signal (scipy's hilbert)."""
    from scipy.signal import hilbert  # type: ignore[import-untyped]

    part = signals.segment_slice(time, segment.t_start, segment.t_end)
    values = pressure[part]
    trend = np.polyval(np.polyfit(time[part], values, 1), time[part])
    phase: FloatArray = np.unwrap(np.angle(hilbert(values - trend)))
    return phase


def phasors(
    time: FloatArray, phase: FloatArray, channels: dict[str, FloatArray], start: float, end: float
) -> dict[str, complex]:
    """Each channel's complex amplitude on the carrier ``phase`` over ``[start, end)``.

    Least squares of ``offset + drift t + a cos(phase) + b sin(phase)``: ``X = a - j b``.
    ``time``, ``phase`` and the channels share one base.
    """
    part = signals.segment_slice(time, start, end)
    t = time[part] - np.mean(time[part])
    basis = np.column_stack([np.ones_like(t), t, np.cos(phase[part]), np.sin(phase[part])])
    result = {}
    for key, values in channels.items():
        coefficients, *_ = np.linalg.lstsq(basis, values[part], rcond=None)
        result[key] = complex(coefficients[2], -coefficients[3])
    return result


def sweep_response(
    time: FloatArray,
    pressure: FloatArray,
    predicted: FloatArray,
    measured: FloatArray,
    segment: Segment,
) -> list[dict[str, float]]:
    """Gain (channel unit per Pa) and phase (deg) to ``p_i`` per band, measured and model."""
    part = signals.segment_slice(time, segment.t_start, segment.t_end)
    t = time[part]
    phase = instantaneous_phase(time, pressure, segment)
    channels = {"p_i": pressure[part], "model": predicted[part], "measured": measured[part]}
    points = []
    for centre, start, end in band_windows(segment):
        x = phasors(t, phase, channels, start, end)
        if x["p_i"] == 0 or x["measured"] == 0:
            continue
        model, meas = x["model"] / x["p_i"], x["measured"] / x["p_i"]
        points.append(
            {
                "frequency_hz": centre,
                "gain_measured": abs(meas),
                "gain_model": abs(model),
                "phase_measured_deg": math.degrees(np.angle(meas)),
                "phase_model_deg": math.degrees(np.angle(model)),
                "gain_ratio_pct": 100.0 * abs(model) / abs(meas),
                "phase_error_deg": math.degrees(np.angle(model / meas)),
            }
        )
    if not points:
        raise SignalError(f"sweep {segment.t_start:.2f}-{segment.t_end:.2f} s: no band to measure")
    return points


def _sweep_metrics(points: list[dict[str, float]]) -> dict[str, float]:
    """The worst band: largest ``|model / measured - 1|`` of the complex response."""
    errors = [
        abs(
            p["gain_ratio_pct"]
            / 100.0
            * complex(
                math.cos(math.radians(p["phase_error_deg"])),
                math.sin(math.radians(p["phase_error_deg"])),
            )
            - 1
        )
        for p in points
    ]
    worst = points[int(np.argmax(errors))]
    return {
        "worst_hz": worst["frequency_hz"],
        "gain_ratio_pct": worst["gain_ratio_pct"],
        "phase_error_deg": worst["phase_error_deg"],
        "worst_error_pct": 100.0 * max(errors),
        "mean_gain_ratio_pct": float(np.mean([p["gain_ratio_pct"] for p in points])),
        "mean_phase_error_deg": float(np.mean([p["phase_error_deg"] for p in points])),
    }


# --------------------------------------------------------------------------- ramps, steps


def _moved(values: FloatArray, share: float) -> int:
    """First index where ``values`` has moved ``share`` of its total change from its start."""
    change = values[-1] - values[0]
    progress = (values - values[0]) / change if change != 0 else np.zeros_like(values)
    return min(int(np.searchsorted(np.maximum.accumulate(progress), share)), values.size - 1)


def _ramp_metrics(
    pressure: FloatArray, predicted: FloatArray, measured: FloatArray
) -> dict[str, float]:
    """Static map slope (unit per Pa) and stick region (Pa of ``p_i``), model and measured."""
    slopes = [float(np.polyfit(pressure, y, 1)[0]) for y in (predicted, measured)]
    sticks = [
        abs(float(pressure[_moved(y, STICK_SHARE)] - pressure[0])) for y in (predicted, measured)
    ]
    return {
        "map_slope_model": slopes[0],
        "map_slope_measured": slopes[1],
        "map_gain_ratio_pct": 100.0 * slopes[0] / slopes[1] if slopes[1] != 0 else math.inf,
        "stick_model_pa": sticks[0],
        "stick_measured_pa": sticks[1],
        "stick_error_pct": 100.0 * (sticks[0] - sticks[1]) / _span(pressure),
    }


def hysteresis(
    rise: tuple[FloatArray, FloatArray], fall: tuple[FloatArray, FloatArray], points: int = 50
) -> float:
    """Mean width of the loop between a rise and a fall: ``|y_rise - y_fall|`` over ``p_i``.

    Each is ``(p_i, output)``; the width is taken on a common grid of ``p_i`` inside both.
    """
    low = max(float(np.min(rise[0])), float(np.min(fall[0])))
    high = min(float(np.max(rise[0])), float(np.max(fall[0])))
    grid = np.linspace(low + 0.05 * (high - low), high - 0.05 * (high - low), points)
    on = [np.interp(grid, *_sorted_map(p, y)) for p, y in (rise, fall)]
    return float(np.mean(np.abs(on[0] - on[1])))


def _sorted_map(pressure: FloatArray, output: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The map sorted by pressure (for interpolation)."""
    order = np.argsort(pressure)
    return pressure[order], output[order]


def step_response(
    time: FloatArray, values: FloatArray, before: float, after: float
) -> dict[str, float]:
    """10-90 % rise time (s), overshoot (% of the change) and 2 % settling time (s).

    ``before`` and ``after`` are the levels before and after the step; times from the
    window's first sample.
    """
    change = after - before
    if change == 0:
        raise SignalError("a step without a change")
    progress = (values - before) / change
    reached = np.maximum.accumulate(progress)
    last = time.size - 1
    t10 = float(time[min(int(np.searchsorted(reached, 0.1)), last)])
    t90 = float(time[min(int(np.searchsorted(reached, 0.9)), last)])
    outside = np.flatnonzero(np.abs(progress - 1.0) > SETTLING_BAND)
    settled = float(time[min(int(outside[-1]) + 1, last)]) if outside.size else float(time[0])
    return {
        "rise_time_s": t90 - t10,
        "overshoot_pct": 100.0 * max(float(np.max(progress)) - 1.0, 0.0),
        "settling_s": settled - float(time[0]),
    }


def _step_metrics(
    time: FloatArray, predicted: FloatArray, measured: FloatArray
) -> dict[str, float]:
    """Step response of model and measurement; levels from the window's first and last 10 %."""
    tenth = max(time.size // 10, 1)
    result: dict[str, float] = {}
    for name, y in (("model", predicted), ("measured", measured)):
        before, after = float(np.median(y[:tenth])), float(np.median(y[-tenth:]))
        for key, value in step_response(time, y, before, after).items():
            result[f"{key}_{name}"] = value
    result["rise_time_ratio_pct"] = (
        100.0 * result["rise_time_s_model"] / max(result["rise_time_s_measured"], 1e-9)
    )
    result["overshoot_error_pct"] = (
        result["overshoot_pct_model"] - result["overshoot_pct_measured"]
    )
    result["settling_error_s"] = result["settling_s_model"] - result["settling_s_measured"]
    return result


# --------------------------------------------------------------------------- any segment


def score(
    segment: Segment,
    window: tuple[float, float],
    time: FloatArray,
    pressure: FloatArray,
    predicted: FloatArray,
    measured: FloatArray,
    channel_span: float,
) -> dict[str, object]:
    """The metrics of one channel over one segment (``window``: where they are taken, s).

    ``channel_span`` is the channel's range over the recording (normalises a hold's level).
    """
    part = signals.segment_slice(time, *window)
    t, p, model, meas = time[part], pressure[part], predicted[part], measured[part]
    result: dict[str, object] = {}
    if segment.kind == "pulsing":
        period = 1.0 / float(segment.descriptors["frequency_hz"])
        result.update(signals.cycle_metrics(model, meas, t, period).as_dict())
    elif segment.kind == "sweep":
        points = sweep_response(time, pressure, predicted, measured, segment)
        result.update(_sweep_metrics(points))
        result["response"] = points
    elif segment.kind == "ramp":
        result.update(_ramp_metrics(p, model, meas))
    elif segment.kind == "step":
        result.update(_step_metrics(t, model, meas))
    elif segment.kind == "hold":
        result["level_error_pct"] = 100.0 * float(np.mean(model) - np.mean(meas)) / channel_span
    elif segment.kind == "modulated":
        period = 1.0 / float(segment.descriptors["frequency_hz"])
        result["ptp_ratio_pct"] = 100.0 * _span(model) / _span(meas)
        lag = lag_s(time, predicted, measured, part, 0.5 * period)
        result["tau_over_T_pct"] = 100.0 * lag / period
    if segment.kind not in ("pulsing", "hold"):  # a hold's NRMSE is over its noise alone
        result["nrmse"] = signals.nrmse(model, meas) if np.ptp(meas) > 0 else math.inf
    return result
