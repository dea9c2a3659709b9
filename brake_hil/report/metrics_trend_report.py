"""The nightly regression's section of ``trend.html``: each recording's metrics over its runs.

Per recording, a figure of three panels a channel (peak-to-peak ratio, tau/T, NRMSE) against
the run, the reference drawn as a line and its tolerance shaded, values past it in red; above
it, one line per metric that left its tolerance, or that none did
(:mod:`brake_hil.results.metrics_trend`).
"""

from __future__ import annotations

from collections.abc import Sequence
import html

import matplotlib

matplotlib.use("Agg")
from matplotlib.axes import Axes  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from brake_hil.analysis.stamp_scoring import METRIC_KEYS  # noqa: E402
from brake_hil.report.embed import image, png_data_uri  # noqa: E402
from brake_hil.results.metrics_trend import RecordingTrend  # noqa: E402

__all__ = ["metrics_sections"]

DPI = 110
METRIC_WORDS = {
    "ptp_ratio_pct": "peak-to-peak, % of measured",
    "tau_over_T_pct": "tau/T, %",
    "nrmse": "NRMSE (RMS error / measured ptp)",
}


def metrics_sections(trends: Sequence[RecordingTrend]) -> str:
    """The HTML of every recording's section, then how the lines are decided."""
    if not trends:
        return ""
    parts = ["<h2>Regressions and comparisons over time</h2>", _rules()]
    for trend in trends:
        lines = "".join(f"<li>{html.escape(line)}</li>" for line in trend.summary())
        parts.append(
            f"<h3>{html.escape(trend.recording)} ({html.escape(trend.kind)}, rig "
            f"{html.escape(trend.rig)})</h3><ul class=findings>{lines}</ul>"
            f"{image(_figure(trend), f'{trend.recording}: metrics over time')}"
            f"{_runs_table(trend)}"
        )
    return "\n".join(parts)


def _rules() -> str:
    return (
        "<p>Each recording's metrics (the paper's Tables 4-5, the comparator's) per run, in "
        "the order the runs were written. The reference is the regression baseline's value "
        "when <code>--baseline</code> names one, else the recording's first stored run; the "
        "shaded band is the baseline's tolerance (else <code>regress</code>'s default). "
        "Red points are past it. A run replaces an earlier one of the same recording, model "
        "file and brake_hil version, so the points are the model or tool versions tried.</p>"
    )


def _figure(trend: RecordingTrend) -> str:
    channels = trend.channels
    figure, axes = plt.subplots(
        len(channels), len(METRIC_KEYS), figsize=(12, 2.3 * len(channels)), squeeze=False
    )
    x = list(range(1, len(trend.runs) + 1))
    for row, channel in enumerate(channels):
        for column, metric in enumerate(METRIC_KEYS):
            _panel(axes[row, column], trend, channel, metric, x)
    figure.suptitle(f"{trend.recording}: metrics per run against the reference", fontsize=11)
    figure.tight_layout()
    return png_data_uri(figure, DPI)


def _panel(axis: Axes, trend: RecordingTrend, channel: str, metric: str, x: list[int]) -> None:
    values = trend.series(channel, metric)
    shown = [(n, v) for n, v in zip(x, values) if v is not None]
    reference = trend.reference.get(channel, {}).get(metric)
    tolerance = trend.tolerances[metric]
    if reference is not None:
        axis.axhspan(reference - tolerance, reference + tolerance, color="tab:green", alpha=0.2)
        axis.axhline(reference, color="tab:green", lw=0.8)
    for n, value in shown:
        past = reference is not None and abs(value - reference) > tolerance
        axis.plot(n, value, "o", ms=4, color="tab:red" if past else "black")
    axis.plot([n for n, _ in shown], [v for _, v in shown], color="grey", lw=0.8)
    axis.set_title(f"{channel}: {METRIC_WORDS[metric]}", fontsize=9)
    axis.set_xlim(0.5, max(len(x), 2) + 0.5)
    axis.xaxis.set_major_locator(MaxNLocator(integer=True))
    axis.set_xlabel("run (the order written)", fontsize=8)
    axis.tick_params(labelsize=8)
    axis.grid(alpha=0.3)


def _runs_table(trend: RecordingTrend) -> str:
    rows = "".join(
        f"<tr><td>{number}</td><td>{html.escape(run.written_at[:16].replace('T', ' '))}</td>"
        f"<td>{html.escape(run.tool_version)}</td><td>{run.rig_hash[:12]}</td></tr>"
        for number, run in enumerate(trend.runs, start=1)
    )
    return (
        "<details><summary>The runs</summary><table><tr><th>run</th><th>written (UTC)</th>"
        "<th>brake_hil</th><th>rig or model file (SHA-256)</th></tr>"
        f"{rows}</table></details>"
    )
