"""Figures of a comparison of any excitation, one per segment kind.

* the segments over time: ``p_i`` with each segment shaded and named, and each channel
  measured against predicted (the main figure when there is no steady pulsing; beside it,
  ``NAME.segments.png``, when there is, the main figure then being :func:`plot_comparison`'s);
* a sweep's Bode plot (``NAME.sweep.png``): gain and phase to ``p_i`` against frequency,
  measured and model, per channel;
* a ramp's static map (``NAME.ramp.png``): each channel against ``p_i``, rise and fall,
  measured and model: the hysteresis loop and its stick region.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
from matplotlib.figure import Figure  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from brake_hil.analysis import signals  # noqa: E402
from brake_hil.analysis.segment_comparison import RecordingComparison  # noqa: E402
from brake_hil.report.plots import TITLES, UNITS, plot_comparison  # noqa: E402

__all__ = ["plot_segments"]

COLOURS = {
    "pulsing": "tab:green",
    "sweep": "tab:purple",
    "modulated": "tab:orange",
    "ramp": "tab:blue",
    "step": "tab:red",
    "hold": "tab:grey",
    "idle": "white",
}
CHANNELS = ("p_b", "F_k", "x_c")


def _beside(path: Path, tag: str) -> Path:
    """``NAME.tag.png`` beside ``path``."""
    return path.with_name(f"{path.stem}.{tag}{path.suffix or '.png'}")


def _save(figure: Figure, path: Path) -> Path:
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=90)
    plt.close(figure)
    return path


def plot_time(comparison: RecordingComparison, path: Path, title: str) -> Path:
    """``p_i`` with the segments shaded and named; each channel measured against predicted."""
    figure, axes = plt.subplots(4, 1, figsize=(13, 11), sharex=True)
    time = comparison.time
    axes[0].plot(time, comparison.master_cylinder_pressure * 1e-6, color="black", lw=0.8)
    axes[0].set_ylabel("p_i, MPa")
    axes[0].set_title("master-cylinder pressure and the segments found", fontsize=10)
    top = float(np.max(comparison.master_cylinder_pressure)) * 1e-6
    for k, scored in enumerate(comparison.segments):
        s = scored.segment
        for axis in axes:
            axis.axvspan(s.t_start, s.t_end, color=COLOURS[s.kind], alpha=0.15, lw=0)
        label = s.kind + (" (steady)" if s.steady else "")
        height = top * (1.0 if k % 2 == 0 else 0.9)  # staggered: short neighbours stay legible
        axes[0].text(
            0.5 * (s.t_start + s.t_end), height, label, ha="center", va="bottom", fontsize=8
        )
    for axis, channel in zip(axes[1:], CHANNELS):
        unit, scale = UNITS[channel]
        axis.plot(
            time, comparison.measured[channel] * scale, color="black", lw=1.0, label="measured"
        )
        axis.plot(
            time,
            comparison.predicted[channel] * scale,
            color="tab:red",
            lw=1.0,
            ls="--",
            label="predicted",
        )
        axis.set_ylabel(unit)
        axis.set_title(TITLES[channel], fontsize=10)
        axis.legend(loc="upper right", fontsize=8)
    for axis in axes:
        axis.grid(alpha=0.3)
    axes[-1].set_xlabel("time, s")
    figure.suptitle(f"{title}: metrics over {comparison.basis.replace('_', ' ')}", fontsize=12)
    return _save(figure, path)


def plot_bode(comparison: RecordingComparison, path: Path, title: str) -> Path:
    """Gain and phase to ``p_i`` against frequency of every sweep, measured and model."""
    return _save(bode_figure(comparison, title), path)


def bode_figure(comparison: RecordingComparison, title: str) -> Figure:
    """:func:`plot_bode`'s figure, not saved (the diagnosis report embeds it)."""
    sweeps = [s for s in comparison.segments if s.segment.kind == "sweep" and s.metrics]
    figure, axes = plt.subplots(2, 3, figsize=(14, 8), sharex=True)
    for n, scored in enumerate(sweeps):
        tag = f" {scored.segment.t_start:.1f} s" if len(sweeps) > 1 else ""
        for col, channel in enumerate(CHANNELS):
            points = scored.metrics[channel]["response"]
            assert isinstance(points, list)
            f = [p["frequency_hz"] for p in points]
            unit, scale = UNITS[channel]
            for row, (key, scaled) in enumerate((("gain", 1e6 * scale), ("phase", 1.0))):
                axis = axes[row, col]
                suffix = "" if key == "gain" else "_deg"
                axis.plot(
                    f,
                    [p[f"{key}_measured{suffix}"] * scaled for p in points],
                    "o-",
                    color="black",
                    ms=3,
                    label=f"measured{tag}",
                )
                axis.plot(
                    f,
                    [p[f"{key}_model{suffix}"] * scaled for p in points],
                    "s--",
                    color="tab:red",
                    ms=3,
                    label=f"model{tag}",
                )
                axis.grid(alpha=0.3, which="both")
            worst = float(scored.metrics[channel]["worst_hz"])  # type: ignore[arg-type]
            for row in (0, 1):
                axes[row, col].axvline(worst, color="tab:orange", lw=0.8, ls=":")
            axes[0, col].set_title(f"{TITLES[channel]}: worst {worst:.1f} Hz", fontsize=10)
            axes[0, col].set_ylabel(f"gain, {unit}/MPa")
            axes[1, col].set_ylabel("phase to p_i, deg")
            axes[1, col].set_xlabel("frequency, Hz")
            if scored.segment.descriptors["law"] == "log":
                axes[1, col].set_xscale("log")
            if n == 0:
                axes[0, col].legend(fontsize=8)
    figure.suptitle(f"{title}: frequency response over the sweep (Bode)", fontsize=12)
    return figure


def plot_static_map(comparison: RecordingComparison, path: Path, title: str) -> Path:
    """Each channel against ``p_i`` over every ramp, rise and fall, measured and model."""
    return _save(static_map_figure(comparison, title), path)


def static_map_figure(comparison: RecordingComparison, title: str) -> Figure:
    """:func:`plot_static_map`'s figure, not saved (the diagnosis report embeds it)."""
    ramps = [s for s in comparison.segments if s.segment.kind == "ramp"]
    figure, axes = plt.subplots(1, 3, figsize=(15, 5.5))
    p_i = comparison.master_cylinder_pressure * 1e-6
    for scored in ramps:
        s = scored.segment
        part = signals.segment_slice(comparison.time, s.t_start, s.t_end)
        style = "-" if s.descriptors["direction"] == "rise" else "--"
        for axis, channel in zip(axes, CHANNELS):
            unit, scale = UNITS[channel]
            for source, colour, name in (
                (comparison.measured, "black", "measured"),
                (comparison.predicted, "tab:red", "model"),
            ):
                axis.plot(
                    p_i[part],
                    source[channel][part] * scale,
                    ls=style,
                    color=colour,
                    lw=1.1,
                    label=f"{name}, {s.descriptors['direction']} {s.t_start:.1f} s",
                )
            axis.set_xlabel("p_i, MPa")
            axis.set_ylabel(unit)
            axis.set_title(f"{TITLES[channel]} against p_i", fontsize=10)
            axis.grid(alpha=0.3)
    for axis in axes:
        axis.legend(fontsize=7)
    figure.suptitle(f"{title}: static map and hysteresis over the ramps", fontsize=12)
    return figure


def plot_segments(comparison: RecordingComparison, path: Path, title: str) -> list[Path]:
    """Every figure the comparison calls for; ``path`` is the main one. Returns the paths."""
    written = []
    if comparison.pulsing is not None:
        written.append(plot_comparison(comparison.pulsing, path, title))
        written.append(plot_time(comparison, _beside(path, "segments"), title))
    else:
        written.append(plot_time(comparison, path, title))
    kinds = {s.segment.kind for s in comparison.segments if s.metrics}
    if "sweep" in kinds:
        written.append(plot_bode(comparison, _beside(path, "sweep"), title))
    if "ramp" in kinds:
        written.append(plot_static_map(comparison, _beside(path, "ramp"), title))
    return written
