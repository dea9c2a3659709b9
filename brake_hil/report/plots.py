"""Comparison figure: what a test engineer looks at first.

One PNG per comparison: for each channel, measured and predicted over a few cycles of the
first steady segment and the residual below it; then the seal's hysteresis loop (band-passed
seal force against seal displacement) and the cycle-weighted Table 4-5 metrics.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from brake_hil.analysis import signals  # noqa: E402
from brake_hil.analysis.comparison import Comparison  # noqa: E402

UNITS = {"p_b": ("MPa", 1e-6), "F_k": ("kN", 1e-3), "x_c": ("um", 1e6)}
TITLES = {"p_b": "bore pressure p_b", "F_k": "block force F_k", "x_c": "caliper displacement x_c"}


def plot_comparison(comparison: Comparison, path: Path, title: str, cycles: int = 4) -> Path:
    """Write the measured-vs-predicted figure of ``comparison`` to ``path`` (PNG)."""
    segment = comparison.segments[0]
    period = segment.metrics["p_b"].period_s
    part = signals.segment_slice(
        comparison.time, segment.t_start, min(segment.t_end, segment.t_start + cycles * period)
    )
    time = comparison.time[part]
    metrics = comparison.metrics()
    figure, axes = plt.subplots(
        4, 2, figsize=(13, 11), gridspec_kw={"height_ratios": [3, 1.2, 3, 1.2]}
    )
    cells = [(0, 0), (0, 1), (2, 0)]
    for (row, col), channel in zip(cells, ("p_b", "F_k", "x_c")):
        unit, scale = UNITS[channel]
        measured = comparison.measured[channel][part] * scale
        predicted = comparison.predicted[channel][part] * scale
        top, bottom = axes[row, col], axes[row + 1, col]
        top.plot(time, measured, color="black", lw=1.4, label="measured")
        top.plot(time, predicted, color="tab:red", lw=1.2, ls="--", label="predicted")
        m = metrics[channel]
        top.set_title(
            f"{TITLES[channel]}: ptp {m['ptp_ratio_pct']:.1f} %, "
            f"tau/T {m['tau_over_T_pct']:+.2f} %, NRMSE {m['nrmse']:.3f}",
            fontsize=10,
        )
        top.set_ylabel(unit)
        top.legend(loc="upper right", fontsize=8)
        top.grid(alpha=0.3)
        bottom.plot(time, predicted - measured, color="tab:blue", lw=1.0)
        bottom.axhline(0.0, color="grey", lw=0.8)
        bottom.set_ylabel(f"residual, {unit}")
        bottom.set_xlabel("time, s")
        bottom.grid(alpha=0.3)
    loop_axis = axes[2, 1]
    whole = signals.segment_slice(comparison.time, segment.t_start, segment.t_end)
    rate = 1.0 / float(comparison.time[1] - comparison.time[0])
    middle = slice(whole.start + (whole.stop - whole.start) // 2, None)
    for label, source, color, style in (
        ("measured", comparison.measured, "black", "-"),
        ("predicted", comparison.predicted, "tab:red", "--"),
    ):
        x_c = signals.bandpass(source["x_c"][whole], rate)[middle.start - whole.start :]
        f_k = signals.bandpass(source["F_k"][whole], rate)[middle.start - whole.start :]
        n = min(x_c.size, int(round(2 * period * rate)))
        loop_axis.plot(x_c[:n] * 1e6, f_k[:n] * 1e-3, color=color, ls=style, label=label)
    loop_axis.set_title("hysteresis loop, 4-6 Hz band: F_k against x_c", fontsize=10)
    loop_axis.set_xlabel("x_c, um")
    loop_axis.set_ylabel("F_k, kN")
    loop_axis.legend(fontsize=8)
    loop_axis.grid(alpha=0.3)
    axes[3, 1].axis("off")
    lines = [f"{'channel':8s}{'ptp %':>10s}{'tau/T %':>10s}{'NRMSE':>10s}"]
    for channel, m in metrics.items():
        lines.append(
            f"{channel:8s}{m['ptp_ratio_pct']:10.1f}{m['tau_over_T_pct']:10.2f}{m['nrmse']:10.4f}"
        )
    axes[3, 1].text(0.0, 0.9, "\n".join(lines), family="monospace", va="top", fontsize=10)
    figure.suptitle(title, fontsize=12)
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=90)
    plt.close(figure)
    return path
