"""The rig file's LTI model against a recording of any excitation, scored per segment.

:func:`compare_segments` splits the recording (:func:`segmentation.find_segments`), runs
the model over the whole recording from the measured ``p_i`` (30 Hz low-passed, as
:mod:`comparison` does) and scores every segment with the metric that fits its kind
(:mod:`segment_metrics`). The steady pulsing at the rig's excitation frequency is scored
exactly as :func:`comparison.compare` scores it (each segment's model derived at its own
mean pressure); every other segment is scored against one model derived at the
recording's operating point, the mean ``p_i`` over its segments that are neither idle nor
steady pulsing.

The recording's metrics (the contract's ``ptp_ratio_pct``, ``tau_over_T_pct``, ``nrmse``
per channel) are over the steady cycles when there are any (``basis`` ``steady_cycles``:
today's numbers, unchanged), else over every segment that is not idle (``basis``
``non_idle_segments``): the peak-to-peak ratio and NRMSE of all their samples together, and
``tau`` the duration-weighted mean of each segment's cross-correlation lag, over the rig's
excitation period ``T``.
"""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

from brake_hil.analysis import segment_metrics, signals
from brake_hil.analysis.comparison import Comparison, compare, conditioned_channels, predict
from brake_hil.analysis.recording import Recording
from brake_hil.analysis.segmentation import Segment, find_segments
from brake_hil.errors import SignalError
from brake_hil.physics.parameters import derive_parameters
from brake_hil.physics.rig import Rig
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray

__all__ = [
    "RecordingComparison",
    "ScoredSegment",
    "compare_segments",
    "operating_pressure",
    "score_prediction",
]

STEP_WINDOW_S = 1.0
"""A step is scored from just before it to the end of the segment after it, at most this long."""


SPAN_LAG_S = 0.5
"""The longest lag (s) sought over a span of ramps and holds (nothing repeats there)."""


@dataclass(frozen=True)
class ScoredSegment:
    """One segment and its metrics per channel (``{}`` for idle, or when unscored)."""

    segment: Segment
    mean_pressure: float  # Pa, mean p_i over the segment
    metrics: dict[str, dict[str, object]]  # channel -> metric -> value
    unscored: str = ""  # why the segment has no metrics ("" when it has)

    def as_dict(self, response: bool = True) -> dict[str, object]:
        """JSON: the segment, its metric's name and the metrics.

        A steady segment keeps today's ``t_start``, ``t_end``, ``mean_pressure``, ``metrics``.
        ``response=False`` leaves out a sweep's per-band points (its summary stays).
        """
        s = self.segment
        metrics = {
            channel: {key: value for key, value in m.items() if response or key != "response"}
            for channel, m in self.metrics.items()
        }
        document: dict[str, object] = {
            "t_start": s.t_start,
            "t_end": s.t_end,
            "mean_pressure": self.mean_pressure,
            "metrics": metrics,
            **s.as_dict(),
            "metric": segment_metrics.METRIC_NAMES.get(s.kind, "none"),
        }
        if self.unscored:
            document["unscored"] = self.unscored
        return document


@dataclass(frozen=True)
class RecordingComparison:
    """Predicted against measured over every segment of a recording."""

    segments: list[ScoredSegment]
    pulsing: Comparison | None  # today's comparison of the steady pulsing, when there is any
    time: FloatArray  # s
    predicted: dict[str, FloatArray]  # per channel, the prediction each segment is scored on
    measured: dict[str, FloatArray]  # per channel, low-passed
    master_cylinder_pressure: FloatArray  # Pa, low-passed
    operating_pressure: float  # Pa, where the model of the other segments is derived
    excitation_hz: float  # the rig's: T of tau_over_T on the non-idle basis

    @property
    def basis(self) -> str:
        """``steady_cycles`` or ``non_idle_segments``: what :meth:`metrics` is taken over."""
        return "steady_cycles" if self.pulsing is not None else "non_idle_segments"

    def metrics(self) -> dict[str, dict[str, float]]:
        """``{channel: {ptp_ratio_pct, tau_over_T_pct, nrmse, ...}}`` over :attr:`basis`."""
        if self.pulsing is not None:
            return self.pulsing.metrics()
        scored = [s for s in self.segments if s.segment.kind != "idle" and not s.unscored]
        if not scored:
            raise SignalError("nothing but idle: no segment to score the model on")
        parts = [
            signals.segment_slice(self.time, s.segment.t_start, s.segment.t_end) for s in scored
        ]
        period = 1.0 / self.excitation_hz
        result = {}
        for key in OUTPUT_CHANNELS:
            model = np.concatenate([self.predicted[key][p] for p in parts])
            meas = np.concatenate([self.measured[key][p] for p in parts])
            tau = self._lag(key, scored, period)
            result[key] = {
                "ptp_ratio_pct": 100.0 * float(np.ptp(model)) / float(np.ptp(meas)),
                "tau_over_T_pct": 100.0 * tau / period,
                "nrmse": signals.nrmse(model, meas),
                "tau_s": tau,
                "samples": float(model.size),
            }
        return result

    def _lag(self, key: str, scored: list[ScoredSegment], period: float) -> float:
        """Duration-weighted lag (s) of ``key`` over the segments that show one.

        Oscillations and steps; a ramp's lag is its offset (a shifted ramp is the ramp
        plus a constant), so with none of those the lag is taken over the whole non-idle
        span at once, where the ramps' corners show it (within ``SPAN_LAG_S``).
        """
        showing = [s.segment for s in scored if s.segment.kind not in ("ramp", "hold")]
        spans = [(s.t_start, s.t_end) for s in showing]
        most = 0.5 * period  # an oscillation repeats: a lag is known within half a period
        if not spans:
            spans = [(scored[0].segment.t_start, scored[-1].segment.t_end)]
            most = SPAN_LAG_S
        lags = [
            segment_metrics.lag_s(
                self.time,
                self.predicted[key],
                self.measured[key],
                signals.segment_slice(self.time, a, b),
                most,
            )
            for a, b in spans
        ]
        return float(np.average(lags, weights=[b - a for a, b in spans]))

    def as_dict(self) -> dict[str, object]:
        """The JSON of ``brake-hil compare``: ``metrics``, ``basis``, ``segments``."""
        return {
            "metrics": self.metrics(),
            "basis": self.basis,
            "operating_pressure": self.operating_pressure,
            "segments": [s.as_dict() for s in self.segments],
        }


def operating_pressure(pressure: FloatArray, time: FloatArray, segments: list[Segment]) -> float:
    """Mean ``p_i`` (Pa) over the segments neither idle nor steady (all of it if none)."""
    parts = [
        pressure[signals.segment_slice(time, s.t_start, s.t_end)]
        for s in segments
        if s.kind != "idle" and not s.steady
    ]
    values = np.concatenate(parts) if parts and sum(p.size for p in parts) else pressure
    return float(np.mean(values))


def _window(segments: list[Segment], k: int, end_of_recording: float) -> tuple[float, float]:
    """Where segment ``k``'s metrics are taken (s): a step's reaches into what follows."""
    s = segments[k]
    if s.kind != "step":
        return s.t_start, s.t_end
    following = segments[k + 1].t_end if k + 1 < len(segments) else end_of_recording
    start = max(s.t_start - 0.1, segments[k - 1].t_start if k > 0 else s.t_start - 0.1)
    return start, min(following, s.t_start + STEP_WINDOW_S, end_of_recording)


def _scored(
    segments: list[Segment],
    k: int,
    time: FloatArray,
    filtered: dict[str, FloatArray],
    predicted: dict[str, FloatArray],
) -> ScoredSegment:
    """Segment ``k`` scored on every channel, or unscored with the reason."""
    s = segments[k]
    part = signals.segment_slice(time, s.t_start, s.t_end)
    if part.stop - part.start < 3:
        edge = min(part.start, time.size - 1)
        return ScoredSegment(s, float(filtered["p_i"][edge]), {}, "too short to score")
    mean = float(np.mean(filtered["p_i"][part]))
    if s.kind == "idle":
        return ScoredSegment(s, mean, {}, "idle: nothing to score")
    window = _window(segments, k, float(time[-1]))
    metrics: dict[str, dict[str, object]] = {}
    try:
        for key in OUTPUT_CHANNELS:
            span = max(float(np.ptp(filtered[key])), float(np.finfo(float).tiny))
            metrics[key] = segment_metrics.score(
                s, window, time, filtered["p_i"], predicted[key], filtered[key], span
            )
    except SignalError as err:
        return ScoredSegment(s, mean, {}, str(err))
    undefined = _not_finite(metrics)
    if undefined:
        return ScoredSegment(s, mean, {}, f"{undefined} is undefined over this segment")
    return ScoredSegment(s, mean, metrics)


def _not_finite(metrics: dict[str, dict[str, object]]) -> str:
    """``channel metric`` of the first value that is not a finite number, else ``""``."""
    for channel, values in metrics.items():
        for key, value in values.items():
            if isinstance(value, float) and not math.isfinite(value):
                return f"{channel} {key}"
    return ""


def _with_hysteresis(
    scored: list[ScoredSegment],
    time: FloatArray,
    filtered: dict[str, FloatArray],
    predicted: dict[str, FloatArray],
) -> None:
    """A fall ramp after a rise ramp gets the loop's width, model and measured, per channel."""
    ramps = [s for s in scored if s.segment.kind == "ramp" and s.metrics]
    for rise, fall in zip(ramps, ramps[1:]):
        if (rise.segment.descriptors["direction"], fall.segment.descriptors["direction"]) != (
            "rise",
            "fall",
        ):
            continue
        a = signals.segment_slice(time, rise.segment.t_start, rise.segment.t_end)
        b = signals.segment_slice(time, fall.segment.t_start, fall.segment.t_end)
        p = filtered["p_i"]
        for key in OUTPUT_CHANNELS:
            model = segment_metrics.hysteresis(
                (p[a], predicted[key][a]), (p[b], predicted[key][b])
            )
            meas = segment_metrics.hysteresis((p[a], filtered[key][a]), (p[b], filtered[key][b]))
            span = max(float(np.ptp(filtered[key][a])), float(np.finfo(float).tiny))
            fall.metrics[key].update(
                {
                    "loop_with_rise_at_s": rise.segment.t_start,
                    "loop_width_model": model,
                    "loop_width_measured": meas,
                    "loop_width_error_pct": 100.0 * (model - meas) / span,
                }
            )


def compare_segments(recording: Recording, rig: Rig) -> RecordingComparison:
    """Score the rig's LTI model on every segment of ``recording``, whatever its kind.

    Raises:
        RecordingError: a measured output is missing, or a channel does not vary.
    """
    filtered = conditioned_channels(recording)
    time = recording.time
    rate = recording.sample_rate
    segments = find_segments(time, filtered["p_i"], rate, rig.excitation_hz)
    pulsing = compare(recording, rig) if any(s.steady for s in segments) else None
    operating = operating_pressure(filtered["p_i"], time, segments)
    whole = predict(filtered["p_i"], derive_parameters(rig, operating), 1.0 / rate)
    predicted = {key: whole[key].copy() for key in OUTPUT_CHANNELS}
    scored: list[ScoredSegment] = []
    steady = iter(pulsing.segments if pulsing is not None else [])
    for k, s in enumerate(segments):
        if s.steady:
            today = next(steady)
            part = signals.segment_slice(time, today.t_start, today.t_end)
            for key in OUTPUT_CHANNELS:
                assert pulsing is not None
                predicted[key][part] = pulsing.predicted[key][part]
            metrics = {key: dict(m.as_dict()) for key, m in today.metrics.items()}
            scored.append(ScoredSegment(s, today.mean_pressure, metrics))  # type: ignore[arg-type]
        else:
            scored.append(_scored(segments, k, time, filtered, predicted))
    _with_hysteresis(scored, time, filtered, predicted)
    return RecordingComparison(
        segments=scored,
        pulsing=pulsing,
        time=time,
        predicted=predicted,
        measured={key: filtered[key] for key in OUTPUT_CHANNELS},
        master_cylinder_pressure=filtered["p_i"],
        operating_pressure=operating,
        excitation_hz=rig.excitation_hz,
    )


def score_prediction(
    recording: Recording, predicted: dict[str, FloatArray], excitation_hz: float, operating: float
) -> RecordingComparison:
    """Score a given prediction on every segment (``regress``'s replays of any excitation).

    The prediction (``p_b``, ``F_k``, ``x_c``, raw, on the recording's time base) and the
    recording are 30 Hz low-passed alike.

    Args:
        recording: the measurement.
        predicted: what a model predicted from its raw ``p_i``.
        excitation_hz: the excitation frequency (its steady pulsing is scored per cycle).
        operating: the model's operating point (Pa), reported.

    Raises:
        RecordingError: a measured output is missing, or a channel does not vary.
        SignalError: nothing but idle (from :meth:`RecordingComparison.metrics`).
    """
    filtered = conditioned_channels(recording)
    rate = recording.sample_rate
    model = {key: signals.lowpass(value, rate) for key, value in predicted.items()}
    time = recording.time
    segments = find_segments(time, filtered["p_i"], rate, excitation_hz)
    scored = [_scored(segments, k, time, filtered, model) for k in range(len(segments))]
    _with_hysteresis(scored, time, filtered, model)
    comparison = RecordingComparison(
        segments=scored,
        pulsing=None,
        time=time,
        predicted=model,
        measured={key: filtered[key] for key in OUTPUT_CHANNELS},
        master_cylinder_pressure=filtered["p_i"],
        operating_pressure=operating,
        excitation_hz=excitation_hz,
    )
    comparison.metrics()  # refuse here what has nothing to score
    return comparison
