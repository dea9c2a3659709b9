"""The segments of a comparison as printed lines: what each holds and its metric per channel."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from brake_hil.analysis.segment_comparison import RecordingComparison, ScoredSegment

__all__ = ["segment_lines"]


def _what(scored: ScoredSegment) -> str:
    """What a segment holds, in a few words (pressures in MPa)."""
    s = scored.segment
    d = s.descriptors
    mpa = 1e-6
    if s.kind in ("pulsing", "modulated"):
        mean, half = float(d["mean_pressure"]) * mpa, float(d["amplitude_pa"]) * mpa
        level = f"p_i {mean:.2f} +- {half:.2f} MPa"
        steady = " (steady: Tables 3-5)" if s.steady else ""
        prefix = "mean " if s.kind == "modulated" else ""
        return f"{prefix}{float(d['frequency_hz']):.2f} Hz, {level}{steady}"
    if s.kind == "sweep":
        return (
            f"{float(d['f0_hz']):.1f} -> {float(d['f1_hz']):.1f} Hz ({d['law']}), "
            f"p_i {float(d['mean_pressure']) * mpa:.2f} "
            f"+- {float(d['amplitude_pa']) * mpa:.2f} MPa"
        )
    if s.kind == "ramp":
        return (
            f"{d['direction']} {float(d['rate_pa_per_s']) * mpa:+.3f} MPa/s, "
            f"{float(d['from_pa']) * mpa:.2f} -> {float(d['to_pa']) * mpa:.2f} MPa"
        )
    if s.kind == "step":
        return (
            f"{d['direction']} {float(d['from_pa']) * mpa:.2f} -> "
            f"{float(d['to_pa']) * mpa:.2f} MPa "
            f"in {float(d['rise_time_s']) * 1e3:.0f} ms (10-90 %)"
        )
    return f"p_i {float(d['level_pa']) * mpa:.2f} MPa"


def _metric_line(kind: str, m: dict[str, object]) -> str:
    """One channel's metrics of one segment."""
    f = {key: value for key, value in m.items() if isinstance(value, int | float)}
    if kind == "pulsing":
        return (
            f"ptp {f['ptp_ratio_pct']:.1f} %, tau/T {f['tau_over_T_pct']:+.2f} %, "
            f"NRMSE {f['nrmse']:.4f}, {int(f['cycles'])} cycles"
        )
    if kind == "sweep":
        return (
            f"worst at {f['worst_hz']:.1f} Hz: gain {f['gain_ratio_pct']:.1f} %, phase "
            f"{f['phase_error_deg']:+.1f} deg; mean gain {f['mean_gain_ratio_pct']:.1f} %, "
            f"phase {f['mean_phase_error_deg']:+.1f} deg; NRMSE {f['nrmse']:.4f}"
        )
    if kind == "ramp":
        line = (
            f"map slope {f['map_gain_ratio_pct']:.1f} %, stick {f['stick_model_pa'] * 1e-3:.0f} "
            f"kPa (measured {f['stick_measured_pa'] * 1e-3:.0f}), NRMSE {f['nrmse']:.4f}"
        )
        if "loop_width_error_pct" in f:
            line += f"; loop width {f['loop_width_error_pct']:+.2f} % of range vs rise"
        return line
    if kind == "step":
        return (
            f"rise {f['rise_time_s_measured'] * 1e3:.0f} ms "
            f"(model {f['rise_time_ratio_pct']:.0f} %), "
            f"overshoot {f['overshoot_pct_measured']:.1f} % "
            f"(model {f['overshoot_error_pct']:+.1f}), "
            f"settling {f['settling_s_measured']:.3f} s (model {f['settling_error_s']:+.3f} s)"
        )
    if kind == "hold":
        return f"level {f['level_error_pct']:+.2f} % of the channel's range"
    return (
        f"ptp {f['ptp_ratio_pct']:.1f} %, tau/T {f['tau_over_T_pct']:+.2f} %, "
        f"NRMSE {f['nrmse']:.4f}"
    )


def segment_lines(comparison: RecordingComparison) -> list[str]:
    """``t0-t1 s  kind  what``, then ``channel  metrics`` for each scored segment."""
    from brake_hil.analysis.segment_metrics import METRIC_NAMES

    lines = [f"segments found ({len(comparison.segments)}):"]
    for scored in comparison.segments:
        s = scored.segment
        metric = METRIC_NAMES.get(s.kind, "")
        lines.append(f"  {s.t_start:6.2f}-{s.t_end:6.2f} s  {s.kind:9s} {_what(scored)}")
        if scored.unscored:
            if s.kind != "idle":
                lines.append(f"      not scored: {scored.unscored}")
            continue
        lines.append(f"      {metric}:")
        for channel, m in scored.metrics.items():
            lines.append(f"      {channel:4s} {_metric_line(s.kind, m)}")
    return lines
