"""The diagnosis report's figures of the segments that are not steady pulsing.

A sweep's frequency response (Bode) and a ramp's static map, measured against the improved
model (the verdict's, as fitted; the calibrated baseline when nothing is named), drawn by
the figures ``compare`` draws (:mod:`.segment_plots`) from the diagnosis's own signals: the
30 Hz low-passed recording at the diagnosis's rate, the model simulated over each segment.
"""

from __future__ import annotations

import numpy as np

from brake_hil.analysis import segment_metrics, signals
from brake_hil.analysis.segment_comparison import RecordingComparison, ScoredSegment
from brake_hil.diagnosis.candidates import candidate
from brake_hil.diagnosis.dataset import HELD_OUT_SHARE
from brake_hil.diagnosis.diagnose import Diagnosis
from brake_hil.diagnosis.fitting import Model
from brake_hil.errors import SignalError
from brake_hil.report.embed import png_data_uri
from brake_hil.report.segment_plots import bode_figure, static_map_figure
from brake_hil.topics import OUTPUT_CHANNELS

__all__ = ["segment_figures"]

DPI = 100


def _comparison(diagnosis: Diagnosis) -> RecordingComparison | None:
    """The improved model against the measurement over every sweep and ramp window."""
    ds = diagnosis.dataset
    improved = diagnosis.improved
    model = Model(diagnosis.calibration, [candidate(e) for e in improved.effects], ds)
    predicted = {key: np.full(ds.time.size, np.nan) for key in OUTPUT_CHANNELS}
    scored = []
    for window in ds.segments:
        segment = next(
            (
                s
                for s in ds.found
                if s.kind == window.kind
                and s.t_start <= window.start + 1e-6
                and window.end <= s.t_end + 1e-6
            ),
            None,
        )
        if segment is None or segment.kind not in ("sweep", "ramp"):
            continue
        outputs, index = model.simulate(window, improved.theta[None, :])
        for c, key in enumerate(OUTPUT_CHANNELS):
            predicted[key][index] = outputs[0, c]
        metrics: dict[str, dict[str, object]] = {}
        try:
            for key in OUTPUT_CHANNELS:
                metrics[key] = segment_metrics.score(
                    segment,
                    (window.start, window.end),
                    ds.time,
                    ds.pressure,
                    np.nan_to_num(predicted[key]),
                    ds.measured[key],
                    max(float(np.ptp(ds.measured[key])), 1e-30),
                )
        except SignalError:
            continue
        part = signals.segment_slice(ds.time, window.start, window.end)
        scored.append(ScoredSegment(segment, float(np.mean(ds.pressure[part])), metrics))
    if not scored:
        return None
    return RecordingComparison(
        segments=scored,
        pulsing=None,
        time=ds.time,
        predicted=predicted,
        measured=ds.measured,
        master_cylinder_pressure=ds.pressure,
        operating_pressure=float(np.mean([s.mean_pressure for s in scored])),
        excitation_hz=1.0 / ds.period,
    )


def segment_figures(diagnosis: Diagnosis) -> list[tuple[str, str, str]]:
    """``(data URI, alt text, caption)`` of the Bode plot and the static map, if any."""
    comparison = _comparison(diagnosis)
    if comparison is None:
        return []
    named = " + ".join(diagnosis.improved.effects) or "the calibrated LTI baseline"
    held = round(100 * HELD_OUT_SHARE)
    shown = []
    kinds = {s.segment.kind for s in comparison.segments}
    if "sweep" in kinds:
        shown.append(
            (
                png_data_uri(bode_figure(comparison, "sweep"), DPI),
                "frequency response over the sweep",
                "Gain and phase to p_i per frequency band, measured against the improved "
                f"model ({named}) over the whole sweep; its last {held} % in time (the band "
                "it ends on) was held out of every fit. The dotted line is the worst band.",
            )
        )
    if "ramp" in kinds:
        shown.append(
            (
                png_data_uri(static_map_figure(comparison, "ramps"), DPI),
                "static map over the ramps",
                f"Each output against p_i over the ramps (rise solid, fall dashed), measured "
                f"against the improved model ({named}): the map's slope, its kink where the "
                "seal starts to slide, and the loop between rise and fall.",
            )
        )
    return shown
