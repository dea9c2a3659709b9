"""The diagnosis as a test engineer reads it: one HTML page with its figures beside it.

``DIR/report.html`` shows the verdict in plain words, then measured against baseline against
improved on held-out cycles with residuals, the residual over the phase of the 5 Hz cycle,
harmonic bars (seed Table 1), hysteresis loops, the evidence, the hypotheses and the fitted
parameters with their uncertainty, and the seed's Table 4-5 metrics before and after.
"""

from __future__ import annotations

import html
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
from matplotlib.figure import Figure  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from brake_hil.analysis import signals  # noqa: E402
from brake_hil.diagnosis.candidates import CANDIDATES  # noqa: E402
from brake_hil.diagnosis.diagnose import Diagnosis  # noqa: E402
from brake_hil.diagnosis.evidence import PHASE_BINS  # noqa: E402
from brake_hil.diagnosis.fitting import Model  # noqa: E402
from brake_hil.files import output_file  # noqa: E402
from brake_hil.topics import OUTPUT_CHANNELS  # noqa: E402

REPORT_FILES = (
    "report.html",
    "held_out.png",
    "residual_phase.png",
    "harmonics.png",
    "hysteresis.png",
)
"""The files :func:`write_report` writes into its folder."""
UNITS = {"p_b": ("MPa", 1e-6), "F_k": ("kN", 1e-3), "x_c": ("um", 1e6)}
COLOURS = {"measured": "black", "baseline": "tab:blue", "improved": "tab:red"}


def write_report(diagnosis: Diagnosis, out: Path) -> Path:
    """Write ``report.html`` and its PNG figures into ``out``; return the page's path."""
    out.mkdir(parents=True, exist_ok=True)
    figures = [
        _time_plot(diagnosis, output_file(out, "held_out.png")),
        _phase_plot(diagnosis, output_file(out, "residual_phase.png")),
        _harmonics_plot(diagnosis, output_file(out, "harmonics.png")),
        _loop_plot(diagnosis, output_file(out, "hysteresis.png")),
    ]
    page = output_file(out, "report.html")
    page.write_text(_html(diagnosis, [f.name for f in figures]), encoding="utf-8")
    return page


def _held_out_signals(diagnosis: Diagnosis) -> dict[str, dict[str, np.ndarray]]:
    ds = diagnosis.dataset
    window = ds.held_out[0]
    cal = diagnosis.calibration
    result: dict[str, dict[str, np.ndarray]] = {}
    for label, fitted in (("baseline", diagnosis.baseline), ("improved", diagnosis.improved)):
        known = {c.name: c for c in CANDIDATES}
        model = Model(cal, [known[e] for e in fitted.effects if e in known], ds)
        outputs, index = model.simulate(window, fitted.theta[None, :])
        result[label] = {key: outputs[0, c] for c, key in enumerate(OUTPUT_CHANNELS)}
        result["time"] = {"t": ds.time[index]}
        result["measured"] = {key: ds.measured[key][index] for key in OUTPUT_CHANNELS}
    return result


def _time_plot(diagnosis: Diagnosis, path: Path) -> Path:
    data = _held_out_signals(diagnosis)
    time = data["time"]["t"]
    shown = time < time[0] + 4 * diagnosis.dataset.period
    figure, axes = plt.subplots(2, 3, figsize=(15, 7), gridspec_kw={"height_ratios": [3, 1.3]})
    for column, key in enumerate(OUTPUT_CHANNELS):
        unit, scale = UNITS[key]
        top, bottom = axes[0, column], axes[1, column]
        for label in ("measured", "baseline", "improved"):
            style = "-" if label == "measured" else "--"
            top.plot(
                time[shown],
                data[label][key][shown] * scale,
                style,
                color=COLOURS[label],
                label=label,
                lw=1.3,
            )
        for label in ("baseline", "improved"):
            bottom.plot(
                time[shown],
                (data[label][key] - data["measured"][key])[shown] * scale,
                color=COLOURS[label],
                lw=1.0,
                label=label,
            )
        top.set_title(f"{key}, held-out cycles", fontsize=10)
        top.set_ylabel(unit)
        bottom.set_ylabel(f"residual, {unit}")
        bottom.set_xlabel("time, s")
        bottom.axhline(0.0, color="grey", lw=0.8)
        for axis in (top, bottom):
            axis.grid(alpha=0.3)
        top.legend(fontsize=8)
    figure.suptitle("measured vs baseline (calibrated LTI) vs improved, on data not fitted")
    return _save(figure, path)


def _phase_plot(diagnosis: Diagnosis, path: Path) -> Path:
    figure, axis = plt.subplots(figsize=(7, 4))
    degrees = (np.arange(PHASE_BINS) + 0.5) * 360.0 / PHASE_BINS
    for key, profile in diagnosis.evidence.phase_profile.items():
        axis.plot(degrees, 100 * np.array(profile), marker="o", ms=3, label=key)
    axis.set_xlabel("phase of the input cycle, deg (0: p_i rising through its mean)")
    axis.set_ylabel("baseline RMS residual, % of ptp")
    axis.set_title("where in the 5 Hz cycle the baseline misses")
    axis.grid(alpha=0.3)
    axis.legend()
    return _save(figure, path)


def _harmonics_plot(diagnosis: Diagnosis, path: Path) -> Path:
    harmonics = diagnosis.evidence.harmonics
    keys = list(harmonics.get("measured", {}))
    figure, axes = plt.subplots(1, len(keys), figsize=(4 * max(len(keys), 1), 3.6))
    axes = np.atleast_1d(axes)
    for axis, key in zip(axes, keys):
        measured = np.array(harmonics["measured"][key])[1:]
        predicted = np.array(harmonics["predicted"][key])[1:]
        orders = np.arange(2, 2 + measured.size) * 5
        axis.bar(orders - 1, measured, width=2, color="black", label="measured")
        axis.bar(orders + 1, predicted, width=2, color="tab:blue", label="baseline")
        axis.set_xticks(orders)
        axis.set_title(f"{key}: super-harmonics (seed Table 1)", fontsize=9)
        axis.set_xlabel("Hz")
        axis.set_ylabel("% of energy at 5-25 Hz")
        axis.legend(fontsize=7)
    return _save(figure, path)


def _loop_plot(diagnosis: Diagnosis, path: Path) -> Path:
    data = _held_out_signals(diagnosis)
    rate = 1.0 / diagnosis.dataset.sample_time
    figure, axis = plt.subplots(figsize=(6, 5))
    samples = int(round(diagnosis.dataset.period * rate))
    for label in ("measured", "baseline", "improved"):
        x_c = signals.bandpass(data[label]["x_c"], rate)
        f_k = signals.bandpass(data[label]["F_k"], rate)
        middle = x_c.size // 2
        part = slice(middle, middle + samples)
        axis.plot(x_c[part] * 1e6, f_k[part] * 1e-3, color=COLOURS[label], label=label)
    axis.set_xlabel("x_c (4-6 Hz), um")
    axis.set_ylabel("F_k (4-6 Hz), kN")
    axis.set_title("hysteresis loop, one held-out cycle")
    axis.grid(alpha=0.3)
    axis.legend()
    return _save(figure, path)


def _save(figure: Figure, path: Path) -> Path:
    figure.tight_layout()
    figure.savefig(path, dpi=85)
    plt.close(figure)
    return path


def _metrics_table(diagnosis: Diagnosis) -> str:
    rows = []
    for key in OUTPUT_CHANNELS:
        b = diagnosis.baseline_metrics[key]
        i = diagnosis.improved_metrics[key]
        rows.append(
            f"<tr><td>{key}</td><td>{b['ptp_ratio_pct']:.1f}</td><td>{i['ptp_ratio_pct']:.1f}</td>"
            f"<td>{b['tau_over_T_pct']:+.2f}</td><td>{i['tau_over_T_pct']:+.2f}</td>"
            f"<td>{b['nrmse']:.4f}</td><td>{i['nrmse']:.4f}</td></tr>"
        )
    return (
        "<table><tr><th>channel</th><th>ptp % baseline</th><th>ptp % improved</th>"
        "<th>tau/T % baseline</th><th>tau/T % improved</th><th>NRMSE baseline</th>"
        "<th>NRMSE improved</th></tr>" + "".join(rows) + "</table>"
    )


def _html(diagnosis: Diagnosis, figures: list[str]) -> str:
    verdict = ", ".join(diagnosis.effects) or "no missing physics"
    evidence = "".join(f"<li>{html.escape(line)}</li>" for line in diagnosis.evidence.findings)
    hypotheses = []
    baseline_cost = diagnosis.baseline.held_out_cost
    for fit in sorted(diagnosis.hypotheses, key=lambda h: h.held_out_cost):
        params = ", ".join(
            f"{name} = {value:.4g} ± {fit.uncertainties().get(name, float('nan')):.2g} {unit}"
            for name, value, unit in zip(fit.parameter_names, fit.theta, fit.parameter_units)
        )
        hypotheses.append(
            f"<tr><td>{' + '.join(fit.effects)}</td>"
            f"<td>{baseline_cost / max(fit.held_out_cost, 1e-15):.2f}</td>"
            f"<td>{html.escape(params)}</td></tr>"
        )
    calibration = ", ".join(
        f"{name} x{value:.3f} ({diagnosis.calibration.prior_z()[name]:+.1f} sigma)"
        for name, value in diagnosis.calibration.multipliers.items()
    )
    images = "".join(f'<p><img src="{name}" style="max-width:100%"></p>' for name in figures)
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>brake_hil diagnosis</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:auto}}
td,th{{border:1px solid #ccc;padding:3px 8px}}table{{border-collapse:collapse}}</style>
</head><body>
<h1>Diagnosis: {html.escape(verdict)}</h1>
<p><b>Recording:</b> {html.escape(diagnosis.recording)}<br>
<b>Confidence:</b> {diagnosis.confidence:.2f}<br>
{html.escape(diagnosis.explanation)}</p>
<h2>Seed metrics on held-out data (Tables 4-5)</h2>{_metrics_table(diagnosis)}
{images}
<h2>Evidence</h2><ul>{evidence}</ul>
<h2>Calibrated baseline (multipliers of the nominal rig)</h2><p>{html.escape(calibration)}</p>
<h2>Hypotheses (held-out improvement of mean squared error)</h2>
<table><tr><th>effect</th><th>improvement</th><th>parameters (± one sigma)</th></tr>
{"".join(hypotheses)}</table>
</body></html>
"""
