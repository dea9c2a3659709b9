"""The diagnosis as a test engineer reads it: one HTML page with its figures beside it.

``DIR/report.html`` starts with a short summary in plain words (what was wrong, what physics,
how much better, how sure, what to check on the rig), then the seed's Table 4-5 metrics
before and after (one NRMSE definition, said once), measured against baseline against
improved on held-out cycles with residuals, the residual over the phase of the 5 Hz cycle,
harmonic bars (seed Table 1), the seal's hysteresis loop, the evidence, the calibration
(rig values far outside their tolerance said in words), the hypotheses with why each is or
is not the verdict, and the fitted parameters, those the data did not identify apart.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
import html
import math
from pathlib import Path
import re

import matplotlib

matplotlib.use("Agg")
from matplotlib.figure import Figure  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from brake_hil import __version__  # noqa: E402
from brake_hil.diagnosis.candidates import CANDIDATES  # noqa: E402
from brake_hil.diagnosis.diagnose import (  # noqa: E402
    Diagnosis,
    Verdict,
    hypothesis_note,
    ratio,
)
from brake_hil.diagnosis.evidence import PHASE_BINS  # noqa: E402
from brake_hil.diagnosis.fitting import Fit, Model  # noqa: E402
from brake_hil.files import output_file  # noqa: E402
from brake_hil.physics.calibrated_values import VALUE_LABELS  # noqa: E402
from brake_hil.physics.catalogue import CATALOGUE, entry_text  # noqa: E402
from brake_hil.topics import OUTPUT_CHANNELS  # noqa: E402

__all__ = [
    "FLAG_SIGMA",
    "NRMSE_DEFINITION",
    "REPORT_FILES",
    "RIG_CHECKS",
    "calibration_findings",
    "findings",
    "identified",
    "improved_multipliers",
    "write_report",
]

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
DPI = 130
LEGEND_SIZE = 10

NRMSE_DEFINITION = (
    "NRMSE is the RMS of (predicted - measured) over the measured peak-to-peak, per 5 Hz "
    "cycle, averaged over the held-out cycles (the seed's Tables 4-5); every NRMSE on this "
    "page is this one."
)
FLAG_SIGMA = 3.0
"""A calibration multiplier this many prior sigmas from 1 is a finding about the rig file."""
IDENTIFIED_RELATIVE_SIGMA = 0.5
"""A parameter is identified when its one sigma is below this share of its value."""

MULTIPLIER_WORDS: Mapping[str, str] = {
    name: label.report_words for name, label in VALUE_LABELS.items()
}
"""How the calibration table names each calibrated value (``physics.calibrated_values``)."""
RIG_CHECKS: Mapping[str, str] = entry_text("rig_check")
"""What to look at on the rig for each effect: its catalogue entry's ``rig_check`` (live)."""


def write_report(diagnosis: Diagnosis, out: Path, rig_path: Path | None = None) -> Path:
    """Write ``report.html`` and its PNG figures into ``out``; return the page's path.

    Args:
        diagnosis: what :func:`~brake_hil.diagnosis.diagnose.diagnose` found.
        out: the folder (made if missing).
        rig_path: the nominal rig file the diagnosis used, named on the page.
    """
    out.mkdir(parents=True, exist_ok=True)
    figures = [
        _time_plot(diagnosis, output_file(out, "held_out.png")),
        _phase_plot(diagnosis, output_file(out, "residual_phase.png")),
        _harmonics_plot(diagnosis, output_file(out, "harmonics.png")),
        _loop_plot(diagnosis, output_file(out, "hysteresis.png")),
    ]
    page = output_file(out, "report.html")
    page.write_text(_html(diagnosis, [f.name for f in figures], rig_path), encoding="utf-8")
    return page


# --------------------------------------------------------------------------- words


@dataclass(frozen=True)
class Finding:
    """A calibration multiplier far outside its prior: the rig file's value looks off."""

    name: str  # multiplier name
    multiplier: float  # what the data say over the rig file's value
    sigmas: float  # prior sigmas from 1

    @property
    def words(self) -> str:
        """E.g. ``caliper stiffness in the rig file looks 18 % high``."""
        what = MULTIPLIER_WORDS.get(self.name, self.name.replace("_", " "))
        off = 1.0 / self.multiplier - 1.0  # file over data, minus one
        direction = "high" if off > 0 else "low"
        return (
            f"{what} in the rig file looks {100 * abs(off):.0f} % {direction} (the data put "
            f"it at {self.multiplier:.2f} of the file's value, {abs(self.sigmas):.1f} sigma "
            "outside the tolerance the rig file states)"
        )


def findings(multipliers: dict[str, float], sigmas: dict[str, float]) -> list[Finding]:
    """Multipliers at least :data:`FLAG_SIGMA` prior sigmas from 1, farthest first.

    Args:
        multipliers: fitted over nominal, by name.
        sigmas: the prior's log-sigma of each (the rig file's tolerance).
    """
    found = [
        Finding(name, value, _sigmas(value, sigmas[name])) for name, value in multipliers.items()
    ]
    return sorted((f for f in found if abs(f.sigmas) >= FLAG_SIGMA), key=lambda f: -abs(f.sigmas))


def _sigmas(multiplier: float, sigma: float) -> float:
    return math.log(multiplier) / sigma if multiplier > 0 and sigma > 0 else 0.0


def improved_multipliers(diagnosis: Diagnosis) -> dict[str, float]:
    """The calibration multipliers the improved model was fitted with (the verdict's)."""
    parameters = diagnosis.improved.parameters()
    return {
        name: parameters.get(f"calibration.{name}", value)
        for name, value in diagnosis.calibration.multipliers.items()
    }


def calibration_findings(diagnosis: Diagnosis) -> list[Finding]:
    """The improved model's multipliers far outside the rig file's tolerances."""
    return findings(improved_multipliers(diagnosis), diagnosis.calibration.sigmas)


def identified(value: float, sigma: float) -> bool:
    """True when the data pin a parameter down: a finite sigma under half its value."""
    return math.isfinite(sigma) and sigma < IDENTIFIED_RELATIVE_SIGMA * abs(value)


def _text(raw: str) -> str:
    """HTML of a plain text; ``code`` in double backticks as <code>."""
    escaped = html.escape(raw)
    return re.sub(r"``(.+?)``", r"<code>\1</code>", escaped).replace("``", "")


def _confidence_words(confidence: float, doubt: str | None = None) -> str:
    if confidence >= 0.9:
        return "high"
    if doubt is not None and confidence >= 0.5:
        return "moderate: not sure it is alone (what to check, below)"
    if confidence >= 0.7:
        return "moderate: check the runner-up below"
    return "low: treat the verdict as a hint, not a finding"


def _percent(value: float) -> str:
    return f"{100 * value:.2f} %"


def _summary(diagnosis: Diagnosis, findings: list[Finding]) -> str:
    effects = [e for e in diagnosis.effects if e in CATALOGUE]
    before, after = diagnosis.baseline_metrics, diagnosis.improved_metrics
    worst = max(before, key=lambda k: before[k]["nrmse"])
    items = []
    if effects:
        titles = "; ".join(f"{CATALOGUE[e].title} (<code>{e}</code>)" for e in effects)
        items.append(f"<b>What was wrong:</b> the rig file's LTI model leaves out {titles}.")
        physics = " ".join(_text(CATALOGUE[e].physics) for e in effects)
        items.append(f"<b>The physics:</b> {physics}")
        items.append(
            f"<b>How much better:</b> on cycles no fit saw, {worst} NRMSE "
            f"{_percent(before[worst]['nrmse'])} with the calibrated LTI model, "
            f"{_percent(after[worst]['nrmse'])} with the improved one "
            f"(peak-to-peak {before[worst]['ptp_ratio_pct']:.1f} % -> "
            f"{after[worst]['ptp_ratio_pct']:.1f} % of measured)."
        )
    elif "unexplained" in diagnosis.effects:
        items.append(
            "<b>What was wrong:</b> the LTI model misses the recording by more than its noise, "
            f"and none of the {len(CANDIDATES)} candidate physics explains it "
            f"({worst} NRMSE {_percent(before[worst]['nrmse'])}). Something outside the "
            "library: look at the sensors' calibration and the rig's build."
        )
    else:
        items.append(
            "<b>What was wrong:</b> nothing the data can show: the calibrated LTI model "
            f"explains the recording (worst channel {worst}, NRMSE "
            f"{_percent(before[worst]['nrmse'])})."
        )
    doubt = diagnosis.summary.doubt(tuple(effects)) if effects else None
    items.append(
        f"<b>How sure:</b> {_confidence_words(diagnosis.confidence, doubt)} "
        f"(confidence {diagnosis.confidence:.2f})."
    )
    checks = [RIG_CHECKS[e] for e in effects if e in RIG_CHECKS]
    checks += [f"what else is there: {doubt}"] if doubt is not None else []
    checks += [f.words for f in findings]
    if checks:
        listed = "".join(f"<li>{_text(c)}</li>" for c in checks)
        items.append(f"<b>What to check on the rig:</b><ul>{listed}</ul>")
    else:
        items.append("<b>What to check on the rig:</b> nothing stands out.")
    return "<ul class=summary>" + "".join(f"<li>{i}</li>" for i in items) + "</ul>"


# --------------------------------------------------------------------------- figures


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
        top.plot(
            time[shown],
            data["measured"][key][shown] * scale,
            color=COLOURS["measured"],
            lw=3.0,
            alpha=0.45,
            label="measured",
        )
        for label in ("baseline", "improved"):
            top.plot(
                time[shown],
                data[label][key][shown] * scale,
                "--",
                color=COLOURS[label],
                label=label,
                lw=1.4,
            )
        for label in ("baseline", "improved"):
            bottom.plot(
                time[shown],
                (data[label][key] - data["measured"][key])[shown] * scale,
                color=COLOURS[label],
                lw=1.0,
                label=label,
            )
        top.set_title(f"{key}, held-out cycles", fontsize=11)
        top.set_ylabel(unit)
        bottom.set_ylabel(f"residual, {unit}")
        bottom.set_xlabel("time, s")
        bottom.axhline(0.0, color="grey", lw=0.8)
        for axis in (top, bottom):
            axis.grid(alpha=0.3)
        top.legend(fontsize=LEGEND_SIZE)
    figure.suptitle("measured vs baseline (calibrated LTI) vs improved, on data not fitted")
    return _save(figure, path)


def _phase_plot(diagnosis: Diagnosis, path: Path) -> Path:
    figure, axis = plt.subplots(figsize=(8, 4.5))
    degrees = (np.arange(PHASE_BINS) + 0.5) * 360.0 / PHASE_BINS
    for key, profile in diagnosis.evidence.phase_profile.items():
        axis.plot(degrees, 100 * np.array(profile), marker="o", ms=3, label=key)
    axis.set_xlabel("phase of the input cycle, deg (0: p_i rising through its mean)")
    axis.set_ylabel("baseline RMS residual, % of ptp")
    axis.set_title("where in the 5 Hz cycle the baseline misses")
    axis.grid(alpha=0.3)
    axis.legend(fontsize=LEGEND_SIZE)
    return _save(figure, path)


def _harmonics_plot(diagnosis: Diagnosis, path: Path) -> Path:
    harmonics = diagnosis.evidence.harmonics
    keys = list(harmonics.get("measured", {}))
    columns = 2
    rows = max(1, math.ceil(len(keys) / columns))
    figure, axes = plt.subplots(rows, columns, figsize=(12, 3.8 * rows), squeeze=False)
    axes = axes.ravel()
    for spare in axes[len(keys) :]:
        spare.axis("off")
    for axis, key in zip(axes, keys):
        measured = np.array(harmonics["measured"][key])[1:]
        predicted = np.array(harmonics["predicted"][key])[1:]
        orders = np.arange(2, 2 + measured.size) * 5
        axis.bar(orders - 1, measured, width=2, color="black", label="measured")
        axis.bar(orders + 1, predicted, width=2, color="tab:blue", label="baseline")
        axis.set_xticks(orders)
        axis.set_title(f"{key}: super-harmonics (seed Table 1)", fontsize=10)
        axis.set_xlabel("Hz")
        axis.set_ylabel("% of energy at 5-25 Hz")
        axis.legend(fontsize=LEGEND_SIZE)
    return _save(figure, path)


def _seal_loop(
    diagnosis: Diagnosis, signals_of: dict[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """Seal displacement ``x_s = F_k / k_k - x_c`` (m) and force ``F_s = A_ep p_b - F_k`` (N).

    The seed's characterisation (eq. 21e without the piston's small inertia), from the
    30 Hz low-passed signals, so a stick-slip parallelogram keeps its corners.
    """
    window = diagnosis.dataset.held_out[0]
    parameters = diagnosis.calibration.parameters(window.mean_pressure)
    x_s = signals_of["F_k"] / parameters.block_stiffness - signals_of["x_c"]
    f_s = parameters.piston_area * signals_of["p_b"] - signals_of["F_k"]
    return x_s - x_s.mean(), f_s - f_s.mean()


def _loop_plot(diagnosis: Diagnosis, path: Path) -> Path:
    data = _held_out_signals(diagnosis)
    figure, axis = plt.subplots(figsize=(7, 5.5))
    samples = int(round(2 * diagnosis.dataset.period / diagnosis.dataset.sample_time))
    for label in ("measured", "baseline", "improved"):
        x_s, f_s = _seal_loop(diagnosis, data[label])
        middle = x_s.size // 2
        part = slice(middle, middle + samples)
        measured = label == "measured"
        axis.plot(
            x_s[part] * 1e6,
            f_s[part],
            "-" if measured else "--",
            color=COLOURS[label],
            lw=3.0 if measured else 1.4,
            alpha=0.45 if measured else 1.0,
            label=label,
        )
    axis.set_xlabel("seal displacement x_s = F_k/k_k - x_c, um (mean removed)")
    axis.set_ylabel("seal force F_s = A_ep p_b - F_k, N (mean removed)")
    axis.set_title("seal hysteresis loop, two held-out cycles")
    axis.grid(alpha=0.3)
    axis.legend(fontsize=LEGEND_SIZE)
    return _save(figure, path)


def _save(figure: Figure, path: Path) -> Path:
    figure.tight_layout()
    figure.savefig(path, dpi=DPI)
    plt.close(figure)
    return path


# --------------------------------------------------------------------------- tables


def _metrics_table(diagnosis: Diagnosis) -> str:
    rows = []
    for key in OUTPUT_CHANNELS:
        b = diagnosis.baseline_metrics[key]
        i = diagnosis.improved_metrics[key]
        rows.append(
            f"<tr><td>{key}</td><td>{b['ptp_ratio_pct']:.1f}</td><td>{i['ptp_ratio_pct']:.1f}</td>"
            f"<td>{b['tau_over_T_pct']:+.2f}</td><td>{i['tau_over_T_pct']:+.2f}</td>"
            f"<td>{100 * b['nrmse']:.2f}</td><td>{100 * i['nrmse']:.2f}</td></tr>"
        )
    return (
        f"<p>{NRMSE_DEFINITION}</p>"
        "<table><tr><th>channel</th><th>ptp % baseline</th><th>ptp % improved</th>"
        "<th>tau/T % baseline</th><th>tau/T % improved</th><th>NRMSE % baseline</th>"
        "<th>NRMSE % improved</th></tr>" + "".join(rows) + "</table>"
    )


def _parameter_cells(fit: Fit) -> tuple[str, str]:
    """The hypothesis's own parameters: identified (value ± sigma unit), and not."""
    sigmas = fit.uncertainties()
    known, unknown = [], []
    for name, value, unit in zip(fit.parameter_names, fit.theta, fit.parameter_units):
        if name.startswith("calibration."):
            continue
        short = name.split(".", 1)[-1]
        sigma = sigmas.get(name, float("nan"))
        if identified(float(value), sigma):
            shown_unit = "" if unit in ("", "-") else f" {unit}"
            known.append(f"{short} = {value:.4g} ± {sigma:.2g}{shown_unit}")
        else:
            unknown.append(short)
    return (
        "<br>".join(html.escape(k) for k in known) or "-",
        html.escape(", ".join(unknown)) or "-",
    )


def _hypotheses_table(diagnosis: Diagnosis) -> str:
    base = diagnosis.baseline.held_out_cost
    verdict = _verdict(diagnosis)
    chosen = verdict.chosen
    rows = []
    ranked = sorted(diagnosis.hypotheses, key=lambda h: h.held_out_cost)
    for fit in ranked:
        known, unknown = _parameter_cells(fit)
        note = hypothesis_note(diagnosis.summary, fit.effects, verdict)
        mark = ' class="verdict"' if fit.effects == chosen else ""
        rows.append(
            f"<tr{mark}><td>{' + '.join(fit.effects)}</td>"
            f"<td>{ratio(base, fit.held_out_cost):.1f}</td><td>{html.escape(note)}</td>"
            f"<td>{known}</td><td>{unknown}</td></tr>"
        )
    top = ranked[0] if ranked else None
    lead = ""
    if top is not None and top.effects != chosen:
        note = hypothesis_note(diagnosis.summary, top.effects, verdict)
        lead = (
            f"<p class=why><b>Why the top row is not the verdict:</b> "
            f"{' + '.join(top.effects)} is {html.escape(note)}.</p>"
        )
    return (
        f"{lead}<table><tr><th>hypothesis</th><th>held-out error cut (x)</th>"
        "<th>decision</th><th>parameters the data identified (± one sigma)</th>"
        "<th>not identified (sigma over half the value)</th></tr>" + "".join(rows) + "</table>"
    )


def _verdict(diagnosis: Diagnosis) -> Verdict:
    """The decision as :func:`~brake_hil.diagnosis.diagnose.decide` returned it."""
    named = diagnosis.effects and diagnosis.effects != ("unexplained",)
    chosen = diagnosis.improved.effects if named else None
    return Verdict(diagnosis.effects, diagnosis.confidence, chosen)


def _calibration_table(diagnosis: Diagnosis, flagged: list[Finding]) -> str:
    sigmas = diagnosis.calibration.sigmas
    lti_only = diagnosis.calibration.multipliers
    final = improved_multipliers(diagnosis)
    named = {f.name: f for f in flagged}
    physics = bool(diagnosis.effects) and diagnosis.effects != ("unexplained",)
    rows = []
    for name, sigma in sigmas.items():
        before, after = lti_only[name], final[name]
        z_before, z_after = _sigmas(before, sigma), _sigmas(after, sigma)
        if name in named:
            words = _text(named[name].words)
        elif physics and abs(z_before) >= FLAG_SIGMA:
            words = (
                f"within its tolerance once {' + '.join(diagnosis.effects)} is modelled; the "
                "LTI-only calibration moved it to stand in for the missing physics"
            )
        elif abs(z_after) >= 2.0:
            words = "at the edge of its tolerance"
        else:
            words = "within its tolerance"
        rows.append(
            f"<tr><td>{html.escape(MULTIPLIER_WORDS.get(name, name))}</td>"
            f"<td>x{before:.3f} ({z_before:+.1f})</td><td>x{after:.3f} ({z_after:+.1f})</td>"
            f"<td>{words}</td></tr>"
        )
    return (
        "<p>Multipliers of the rig file's values (1: the file is right; in brackets, sigmas "
        "of the tolerance the rig file states), fitted with the LTI model alone and with "
        f"the verdict's physics. At {FLAG_SIGMA:g} sigma or more with the verdict's "
        "physics, the rig file's value is itself a finding.</p>"
        "<table><tr><th>value</th><th>LTI model alone</th><th>with the verdict's physics"
        "</th><th>finding</th></tr>" + "".join(rows) + "</table>"
    )


def _checks_table(diagnosis: Diagnosis) -> str:
    """The physics checks run on the verdicts considered, one row per check."""
    if not diagnosis.checks:
        return "<p>No hypothesis reached the checks (none cut the error enough).</p>"
    rows = "".join(
        f"<tr><td>{html.escape(effects.replace('+', ' + '))}</td>"
        f"<td>{html.escape(outcome.name.replace('_', ' '))}</td>"
        f"<td>{'passed' if outcome.passed else '<b>failed: set aside</b>'}</td>"
        f"<td>{_text(outcome.finding)}</td></tr>"
        for effects, outcomes in diagnosis.checks.items()
        for outcome in outcomes
    )
    return (
        "<p>Before a hypothesis is named it must explain the misfit clearly better than a "
        "generic form of it does (the decision's rule), and behave as its physics: the error "
        "it removes is on channels its physics reaches, what it leaves is no form its physics "
        "rules out (a delayed channel does not ring), no rival physics outside the library "
        "explains it as well when fitted in its place (a resonant tap for a delay, a late "
        "p_i for a hose), its parameters agree segment by segment, and it survives wider "
        "priors on the rig's values.</p>"
        "<table><tr><th>hypothesis</th><th>check</th><th>result</th>"
        "<th>what was found</th></tr>" + rows + "</table>"
    )


def _forms_table(diagnosis: Diagnosis) -> str:
    """The generic forms fitted to the baseline's residual, best first."""
    residual = diagnosis.residual
    if residual is None:
        return ""
    rows = "".join(
        f"<tr><td>{html.escape(form.form.replace('_', ' '))}</td><td>{form.channel}</td>"
        f"<td>{form.improvement:.2f}</td><td>{_text(form.description)}</td></tr>"
        for form in residual.forms[:6]
    )
    return (
        "<h2>What the misfit looks like (generic forms on the baseline's residual)</h2>"
        f"<p>{_text(residual.summary)}</p><table><tr><th>form</th><th>channel</th>"
        "<th>held-out error cut (x)</th><th>fitted</th></tr>" + rows + "</table>"
    )


def _html(diagnosis: Diagnosis, figures: list[str], rig_path: Path | None) -> str:
    verdict = ", ".join(diagnosis.effects) or "no missing physics"
    findings = calibration_findings(diagnosis)
    evidence = "".join(f"<li>{_text(line)}</li>" for line in diagnosis.evidence.findings)
    ds = diagnosis.dataset
    length = float(ds.time[-1] - ds.time[0] + ds.sample_time)
    images = "".join(
        f'<p><img src="{name}" alt="{name}" style="max-width:100%"></p>' for name in figures
    )
    when = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    rig = html.escape(str(rig_path)) if rig_path is not None else "not given"
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>brake_hil diagnosis: {html.escape(verdict)}</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:auto;line-height:1.4}}
td,th{{border:1px solid #ccc;padding:3px 8px;vertical-align:top}}
table{{border-collapse:collapse}}tr.verdict{{background:#e8f4e8;font-weight:bold}}
p.why{{background:#fff6e0;padding:6px}}ul.summary li{{margin:4px 0}}
.meta{{color:#444}}</style>
</head><body>
<h1>Diagnosis: {html.escape(verdict)}</h1>
<p class=meta><b>Recording:</b> {html.escape(diagnosis.recording)} ({length:.1f} s)<br>
<b>Rig file:</b> {rig}<br>
<b>Made:</b> {when} by brake_hil {__version__}</p>
<h2>In short</h2>
{_summary(diagnosis, findings)}
<p>{_text(diagnosis.explanation)}</p>
<h2>Seed metrics on held-out data (Tables 4-5)</h2>{_metrics_table(diagnosis)}
{images}
<h2>Evidence</h2><ul>{evidence}</ul>
<h2>Calibration: is the rig file right?</h2>{_calibration_table(diagnosis, findings)}
<h2>Hypotheses (held-out mean squared error, baseline over hypothesis)</h2>
{_hypotheses_table(diagnosis)}
<h2>Physics checks</h2>{_checks_table(diagnosis)}
{_forms_table(diagnosis)}
</body></html>
"""
