"""A rig's health over time as a test engineer reads it: one HTML page, a figure per rig.

``OUT/trend.html``, one self-contained file (figures embedded as PNG ``data:`` URIs), says
first, per rig, what moved out of its tolerance in plain words (or that nothing did), then
shows the rig's figure (a small panel per
calibrated value, its multiplier over the rig file's value against the run number with the
rig file's tolerance band shaded and the robust trend line; a panel per effect, how many
times it cuts the held-out error, with the runs whose verdict named it marked), and a table
of the runs (time, recording, verdict, confidence). How a line is decided is said once, at
the end (:mod:`brake_hil.results.trend`).
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import UTC, datetime
import html
import math
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
from matplotlib.artist import Artist  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import FuncFormatter, LogLocator, MaxNLocator, NullLocator  # noqa: E402
import numpy as np  # noqa: E402

from brake_hil import __version__  # noqa: E402
from brake_hil.files import check_output_folder, output_file  # noqa: E402
from brake_hil.report.diagnosis_report import DPI, RIG_CHECKS  # noqa: E402
from brake_hil.report.embed import image, png_data_uri  # noqa: E402
from brake_hil.report.metrics_trend_report import metrics_sections  # noqa: E402
from brake_hil.results.metrics_trend import RecordingTrend  # noqa: E402
from brake_hil.results.trend import (  # noqa: E402
    CONFIDENCE,
    MIN_CHANGE,
    MIN_GROWTH,
    MIN_RUNS,
    NAMED_SHARE,
    OFFSET_SHARE,
    OUTSIDE_SIGMA,
    SIGNIFICANCE,
    TREND_RUNS,
    Movement,
    RigTrend,
    Series,
)
from brake_hil.results.trend_series import advice  # noqa: E402

__all__ = ["PAGE", "write_trend_report"]

PAGE = "trend.html"
"""The page :func:`write_trend_report` writes into its folder."""
COLUMNS = 4
PANEL_SIZE = (3.6, 2.6)  # inches
LEGEND_TOP_INCHES = 0.7  # above the panels: the title, then the legend from 0.38 in down
FOUND = "tab:red"
STEADY = "tab:blue"  # a fitted line that is no trend beyond doubt


def write_trend_report(
    trends: Sequence[RigTrend],
    out: Path,
    database: Path | str | None = None,
    metrics: Sequence[RecordingTrend] = (),
) -> Path:
    """Write ``trend.html`` (its figures inside it) into ``out``; return the page's path.

    Args:
        trends: one per rig (:func:`~brake_hil.results.trend.trends`).
        out: the folder (made if missing; nothing is written through a link leading out).
        database: the results database, named on the page.
        metrics: the regressions' and comparisons' trends, one per recording.

    Raises:
        OutputError: the folder or a file in it cannot be written.
    """
    check_output_folder(out, (PAGE,))
    figures = [_rig_figure(trend) for trend in trends]
    page = output_file(out, PAGE)
    page.write_text(_html(trends, figures, database, metrics), encoding="utf-8")
    return page


# --------------------------------------------------------------------------- figures


def _rig_figure(trend: RigTrend) -> str:
    """Values on the first rows, effects from a new row, four panels a row."""
    values = [s for s in trend.series if s.kind == "value"]
    effects = [s for s in trend.series if s.kind == "effect"]
    value_rows = math.ceil(len(values) / COLUMNS)
    rows = max(1, value_rows + math.ceil(len(effects) / COLUMNS))
    figure, axes = plt.subplots(
        rows,
        COLUMNS,
        figsize=(PANEL_SIZE[0] * COLUMNS, PANEL_SIZE[1] * rows),
        squeeze=False,
    )
    placed = list(zip(axes[:value_rows].ravel(), values))
    placed += list(zip(axes[value_rows:].ravel(), effects))
    used = {id(axis) for axis, _ in placed}
    for axis in axes.ravel():
        if id(axis) not in used:
            axis.axis("off")
    for axis, series in placed:
        if series.kind == "value":
            _value_panel(axis, series)
        else:
            _effect_panel(axis, series)
        axis.set_xlim(0.5, max(len(trend.rows), 2) + 0.5)
        axis.xaxis.set_major_locator(MaxNLocator(integer=True))
        axis.grid(alpha=0.3)
        axis.tick_params(labelsize=8)
        axis.set_xlabel("run (time order)", fontsize=8)
    figure.suptitle(
        f"{trend.rig}: calibrated values (multiplier over the rig file) and effects (how many "
        "times each cuts the held-out error)",
        fontsize=11,
    )
    figure.legend(
        handles=_legend(),
        loc="upper center",
        ncol=6,
        fontsize=8,
        frameon=False,
        bbox_to_anchor=(0.5, 1.0 - 0.38 / figure.get_figheight()),
    )
    figure.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - LEGEND_TOP_INCHES / figure.get_figheight()))
    return png_data_uri(figure, DPI)


def _title(axis: Axes, series: Series) -> None:
    state = {
        Movement.DRIFT: "drifted",
        Movement.OFFSET: "off the rig file",
        Movement.GREW: "grew",
        Movement.OUTSIDE: "outside its band",
        Movement.TOO_FEW: f"under {TREND_RUNS} runs: no trend test",
        Movement.STEADY: "no trend",
    }[series.movement]
    colour = FOUND if series.finding is not None and not series.stand_in else "black"
    state = f"{state} in the LTI model only" if series.stand_in else state
    words = series.words
    if series.modelled is not None:
        words = f"{words}, {advice(series.modelled).words} modelled"
    axis.set_title(f"{words}: {state}", fontsize=9, color=colour)


def _line_style(series: Series) -> dict[str, Any]:
    """A trend beyond doubt in red; a line that is not one, thin and dashed."""
    if series.movement in (Movement.DRIFT, Movement.GREW):
        return {"color": FOUND, "lw": 1.8}
    return {"color": STEADY, "lw": 1.0, "ls": "--"}


def _legend() -> list[Artist]:
    """One legend for every panel, above them."""
    return [
        Patch(color="tab:green", alpha=0.25, label="rig file's tolerance"),
        Line2D([], [], ls="", marker="o", ms=4, color="black", label="identified"),
        Line2D([], [], ls="", marker="o", ms=4, mfc="none", color="grey", label="not identified"),
        Line2D([], [], ls="", marker="o", ms=5, color=FOUND, label="effect named"),
        Line2D([], [], ls="", marker="x", ms=7, color=FOUND, label="far outside its band"),
        Line2D([], [], color=FOUND, lw=1.8, label="trend beyond doubt"),
        Line2D([], [], color=STEADY, lw=1.0, ls="--", label="fitted line, no trend"),
    ]


def _value_panel(axis: Axes, series: Series) -> None:
    x = series.runs + 1
    if series.band is not None:
        axis.axhspan(*series.band, color="tab:green", alpha=0.12, lw=0)
    axis.axhline(1.0, color="tab:green", lw=0.8)
    used = series.used
    axis.plot(x[used], series.values[used], "o", ms=3.5, color="black")
    axis.plot(x[~used], series.values[~used], "o", ms=3.5, mfc="none", color="grey")
    if series.outside:
        far_mask = np.isin(series.runs, series.outside)
        axis.plot(x[far_mask], series.values[far_mask], "x", ms=8, mew=2, color=FOUND)
    if not math.isnan(series.slope):
        axis.plot(x[used], series.line(), **_line_style(series))
    axis.set_ylabel("x rig file", fontsize=8)
    band = series.band or (1.0, 1.0)
    _scale(axis, [*series.values, *band])
    _title(axis, series)


def _scale(axis: Axes, shown: Sequence[float]) -> None:
    """Linear over a narrow range; logarithmic, with plain numbers (1, 2, 5), over a wide one."""
    low, high = min(min(shown), 1.0), max(max(shown), 1.0)
    if high / low < 4.0:
        margin = 0.06 * (high - low) or 0.05
        axis.set_ylim(low - margin, high + margin)
        return
    axis.set_yscale("log")
    axis.set_ylim(low / 1.15, high * 1.15)
    axis.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.yaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    axis.yaxis.set_minor_locator(NullLocator())


def _effect_panel(axis: Axes, series: Series) -> None:
    x = series.runs + 1
    improvement = 10.0**series.values
    axis.axhline(1.0, color="grey", lw=0.8)
    named = series.named
    axis.plot(x[~named], improvement[~named], "o", ms=3.5, mfc="none", color="black")
    axis.plot(x[named], improvement[named], "o", ms=4.5, color=FOUND)
    if not math.isnan(series.slope):
        axis.plot(x, 10.0 ** series.line(), **_line_style(series))
    axis.set_ylabel("held-out gain, x", fontsize=8)
    _scale(axis, [*improvement, 2.0])
    _title(axis, series)


# --------------------------------------------------------------------------- page


def _when(stamp_ns: int | None) -> str:
    if stamp_ns is None:
        return "unknown"
    return datetime.fromtimestamp(stamp_ns / 1e9, UTC).strftime("%Y-%m-%d %H:%M")


def _findings(trend: RigTrend) -> str:
    items = "".join(f"<li>{html.escape(line)}</li>" for line in trend.summary())
    checks = [
        f"<li><b>{html.escape(s.words)}</b>: {html.escape(RIG_CHECKS[s.name])}</li>"
        for s in trend.series
        if s.movement is Movement.GREW and s.name in RIG_CHECKS
    ]
    more = f"<p>What to look at on the rig:</p><ul>{''.join(checks)}</ul>" if checks else ""
    return f"<ul class=findings>{items}</ul>{more}"


def _runs_table(trend: RigTrend) -> str:
    rows = []
    for number, row in enumerate(trend.rows, start=1):
        verdict = ", ".join(row.effects) or "none"
        rows.append(
            f"<tr><td>{number}</td><td>{_when(row.start_ns)}</td>"
            f"<td>{html.escape(row.recording_path)}</td><td>{html.escape(verdict)}</td>"
            f"<td>{html.escape(row.confidence_text)}</td><td>{html.escape(row.tool_version)}</td></tr>"
        )
    return (
        "<table><tr><th>run</th><th>recording start (UTC)</th><th>recording</th>"
        "<th>verdict</th><th>confidence</th><th>brake_hil</th></tr>" + "".join(rows) + "</table>"
    )


def _rig_section(trend: RigTrend, figure: str) -> str:
    first, last = trend.rows[0], trend.rows[-1]
    return f"""<h2>{html.escape(trend.rig)}</h2>
<p class=meta>{len(trend.rows)} diagnoses, {_when(first.start_ns)} to {_when(last.start_ns)};
rig file {html.escape(last.rig_path)} (SHA-256 {last.rig_hash[:12]}...)</p>
{_findings(trend)}
{image(figure, f"{trend.rig} over time")}
<details open><summary>The runs</summary>{_runs_table(trend)}</details>"""


def _rules() -> str:
    return f"""<h2>How a line is decided</h2>
<p>Values are the calibrated LTI model's multipliers over the rig file's value (1 = the file's
value), the band its tolerance (one sigma, as a factor). Only runs whose calibration
identified a value count for it (grey hollow points did not). Effects are how many times
each effect's model cuts the held-out error; red points are runs whose verdict named it.
A trend is a Theil-Sen line over the run number. A line is written only when it is beyond
doubt: the trend test (Mann-Kendall, widened for day-to-day correlation) gives p below
{SIGNIFICANCE:g} and the slope's {100 * CONFIDENCE:.0f} % interval excludes 0, and a value
moved along the line by at least {MIN_CHANGE:.2f} of its tolerance, or an effect grew at
least {10**MIN_GROWTH:.0f} times and was named in at least {NAMED_SHARE:.0%} of the last
third of the runs. A value outside its band in at least {OFFSET_SHARE:.0%} of the runs
(at least {MIN_RUNS} runs), without a trend, says the rig file is off. Whatever the number
of runs, a run whose value sits {OUTSIDE_SIGMA:g} or more tolerances from the rig file's is
said at once (red crosses). The trend test cannot pass on fewer than {TREND_RUNS} runs (a
perfectly monotone series of {TREND_RUNS - 1} gives p above {SIGNIFICANCE:g}): such a series
is "too few runs to test a trend", not steady. Beside an effect named in most runs, the air
fraction is also drawn as the improved model holds it, with that effect modelled (its panel
says so): the LTI model rarely identifies the air beside a seal, the improved model refits it
in every run, and its drift is judged by the same test. On steady synthetic rigs of 30 runs these
rules wrote a line for about 1 % of fleets (the rates: docs/benchmarks.md).</p>"""


def _html(
    trends: Sequence[RigTrend],
    figures: Sequence[str],
    database: Path | str | None,
    metrics: Sequence[RecordingTrend] = (),
) -> str:
    when = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    source = html.escape(str(database)) if database is not None else "not given"
    sections = "\n".join(_rig_section(t, f) for t, f in zip(trends, figures))
    rules = _rules() if trends else ""
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>brake_hil: rig health over time</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:auto;line-height:1.4}}
td,th{{border:1px solid #ccc;padding:3px 8px;vertical-align:top}}
table{{border-collapse:collapse}}ul.findings li{{margin:4px 0;font-weight:bold}}
figure{{margin:8px 0}}.meta{{color:#444}}</style>
</head><body>
<h1>Rig health over time</h1>
<p class=meta><b>Results:</b> {source}<br><b>Made:</b> {when} by brake_hil {__version__}</p>
{sections}
{rules}
{metrics_sections(metrics)}
</body></html>
"""
