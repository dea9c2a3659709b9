"""Run the rig file's LTI model on a recording and score it as the seed does (Tables 4-5).

The input ``p_i`` and the measurements are conditioned alike (30 Hz zero-phase low-pass).
Each steady segment is predicted with the parameters derived at its own mean
master-cylinder pressure (the air modulus of eq. 18 depends on it), from the start of the
recording so that the segment's initial transient has died away, and scored over its whole
cycles. The recording's metrics are the cycle-weighted means over segments.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from brake_hil.analysis import signals
from brake_hil.analysis.recording import Recording
from brake_hil.errors import RecordingError, SignalError
from brake_hil.physics.lti_model import SAMPLE_TIME, caliper_state_space, discretize, simulate
from brake_hil.physics.parameters import ModelParameters, derive_parameters
from brake_hil.physics.rig import Rig
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray

SUMMARY_KEYS = ("ptp_ratio_pct", "tau_over_T_pct", "nrmse")


@dataclass(frozen=True)
class SegmentComparison:
    """Metrics of one steady segment."""

    t_start: float  # s
    t_end: float  # s
    mean_pressure: float  # Pa, mean master-cylinder pressure
    metrics: dict[str, signals.ChannelMetrics]  # keyed p_b, F_k, x_c


@dataclass(frozen=True)
class Comparison:
    """Predicted against measured over a whole recording."""

    segments: list[SegmentComparison]
    time: FloatArray  # s
    predicted: dict[str, FloatArray]  # per channel, the prediction used in each segment
    measured: dict[str, FloatArray]  # per channel, low-passed measurement
    master_cylinder_pressure: FloatArray  # Pa, low-passed input

    def metrics(self) -> dict[str, dict[str, float]]:
        """Cycle-weighted means over segments: ``{channel: {ptp_ratio_pct, ...}}``."""
        result: dict[str, dict[str, float]] = {}
        for channel in OUTPUT_CHANNELS:
            per_segment = [segment.metrics[channel] for segment in self.segments]
            weights = np.array([m.cycles for m in per_segment], dtype=float)
            result[channel] = {
                key: float(np.average([getattr(m, key) for m in per_segment], weights=weights))
                for key in (*SUMMARY_KEYS, "tau_1_s", "tau_2_s", "predicted_ptp", "measured_ptp")
            }
            result[channel]["cycles"] = float(weights.sum())
        return result

    def as_dict(self) -> dict[str, object]:
        """The JSON of ``brake-hil compare`` (docs/interface.md)."""
        return {
            "metrics": self.metrics(),
            "segments": [
                {
                    "t_start": s.t_start,
                    "t_end": s.t_end,
                    "mean_pressure": s.mean_pressure,
                    "metrics": {key: m.as_dict() for key, m in s.metrics.items()},
                }
                for s in self.segments
            ],
        }


def steady_windows(
    recording: Recording, filtered_pressure: FloatArray, rig: Rig
) -> list[tuple[float, float]]:
    """Steady pulsing segments (s) of a recording; the error names the recording's file."""
    try:
        return signals.steady_segments(
            recording.time, filtered_pressure, recording.sample_rate, 1.0 / rig.excitation_hz
        )
    except SignalError as err:
        raise SignalError(f"{recording.path}: {err}") from err


def predict(
    pressure: FloatArray, params: ModelParameters, sample_time: float = SAMPLE_TIME
) -> dict[str, FloatArray]:
    """LTI-model outputs keyed ``p_b``, ``F_k``, ``x_c`` for an input ``pressure`` (Pa).

    Args:
        pressure: the master-cylinder pressure (Pa), one sample per ``sample_time``.
        params: the model's coefficients.
        sample_time: the input's sample period (s): the model is discretised at it.
    """
    outputs = simulate(discretize(caliper_state_space(params), sample_time), pressure)
    return dict(zip(OUTPUT_CHANNELS, outputs))


FLAT_SHARE = 1e-6
"""A channel whose peak-to-peak is at most this share of its largest magnitude does not vary
(a constant, with the rounding of a filter): nothing can be measured from it."""


def check_varying(recording: Recording) -> None:
    """Refuse a recording whose ``p_i`` or a measured output does not vary at all.

    Raises:
        RecordingError: naming the recording and the channel.
    """
    channels = {"p_i": recording.master_cylinder_pressure, **recording.measured()}
    for key, values in channels.items():
        if values is None or values.size == 0:
            continue
        top, bottom = float(np.max(values)), float(np.min(values))
        if not top - bottom > FLAT_SHARE * max(abs(top), abs(bottom)):
            raise RecordingError(
                f"{recording.path}: channel {key} does not vary (every sample between "
                f"{bottom:.6g} and {top:.6g}): nothing to measure"
            )


def conditioned_channels(recording: Recording) -> dict[str, FloatArray]:
    """The seed's 30 Hz zero-phase low-pass of ``p_i`` and every measured output.

    Raises:
        RecordingError: a measured output is missing, or a channel does not vary.
    """
    measured = recording.measured()
    missing = [key for key, value in measured.items() if value is None]
    if missing:
        raise RecordingError(
            f"{recording.path}: no measured {', '.join(missing)} to compare with "
            f"(topics present: {', '.join(recording.topics) or 'none'})"
        )
    check_varying(recording)
    rate = recording.sample_rate
    result = {"p_i": signals.lowpass(recording.master_cylinder_pressure, rate)}
    for key, value in measured.items():
        assert value is not None
        result[key] = signals.lowpass(value, rate)
    return result


def compare(recording: Recording, rig: Rig, params: ModelParameters | None = None) -> Comparison:
    """Score the model on every steady segment of ``recording`` (seed Tables 4-5).

    ``params`` fixes the model coefficients for all segments; by default they are derived
    from ``rig`` at each segment's mean master-cylinder pressure.
    """
    filtered = conditioned_channels(recording)
    time = recording.time
    period = 1.0 / rig.excitation_hz
    windows = steady_windows(recording, filtered["p_i"], rig)
    predicted = {key: np.full(time.size, np.nan) for key in OUTPUT_CHANNELS}
    step = 1.0 / recording.sample_rate  # the recording's own rate, from its stamps
    fixed = None if params is None else predict(filtered["p_i"], params, step)  # serves all
    segments = []
    for start, end in windows:
        part = signals.segment_slice(time, start, end)
        mean_pressure = float(np.mean(filtered["p_i"][part]))
        outputs = fixed or predict(filtered["p_i"], derive_parameters(rig, mean_pressure), step)
        metrics = {}
        for key in OUTPUT_CHANNELS:
            predicted[key][part] = outputs[key][part]
            metrics[key] = signals.cycle_metrics(
                outputs[key][part], filtered[key][part], time[part], period
            )
        segments.append(SegmentComparison(float(start), float(end), mean_pressure, metrics))
    return Comparison(
        segments=segments,
        time=time,
        predicted=predicted,
        measured={key: filtered[key] for key in OUTPUT_CHANNELS},
        master_cylinder_pressure=filtered["p_i"],
    )
