"""The diagnosis as a test engineer reads it: one self-contained HTML page.

``DIR/report.html`` (its figures inside it as PNG ``data:`` URIs: mailed, it keeps them)
starts with a short summary in plain words (what was wrong, what physics, how much better,
how sure, what to check on the rig), then the paper's Table 4-5 metrics before and after (the
one NRMSE of ``compare``, said once, and the diagnosis's own held-out error beside it),
the figures (:mod:`.diagnosis_figures`, each caption true to its figure), the evidence
(the noise ratios in plain words), the calibration (rig values far outside their tolerance
said in words), the hypotheses with the verdict's row marked and why each is or is not the
verdict, the fitted parameters, and the next steps (:mod:`.next_steps`: the command to run
the improved model live, what to check on the rig, how to re-test).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
import html
import math
from pathlib import Path
import re

from brake_hil import __version__
from brake_hil.diagnosis.candidates import CANDIDATES
from brake_hil.diagnosis.diagnose import (
    Diagnosis,
    Verdict,
    held_sentences,
    hypothesis_note,
    ratio,
)
from brake_hil.diagnosis.fitting import Fit
from brake_hil.diagnosis.result import runner_up
from brake_hil.diagnosis.rig_findings import rig_values_text
from brake_hil.diagnosis.ties import tied_with
from brake_hil.files import output_file
from brake_hil.physics.calibrated_values import VALUE_LABELS
from brake_hil.physics.catalogue import CATALOGUE, entry_text
from brake_hil.report.diagnosis_figures import DPI, figures
from brake_hil.report.embed import image
from brake_hil.report.next_steps import next_steps, noise_words
from brake_hil.topics import OUTPUT_CHANNELS

__all__ = [
    "DPI",
    "FLAG_SIGMA",
    "HELD_OUT_ERROR",
    "NRMSE_DEFINITION",
    "REPORT_FILES",
    "RIG_CHECKS",
    "calibration_findings",
    "findings",
    "identified",
    "improved_multipliers",
    "nrmse_as_fraction",
    "write_report",
]

REPORT_FILES = ("report.html",)
"""The files :func:`write_report` writes into its folder (the figures are inside it)."""

NRMSE_DEFINITION = (
    "NRMSE is the paper's (Tables 4-5) and <code>brake-hil compare</code>'s: the RMS of "
    "(predicted - measured) over the measured peak-to-peak of each steady window, as a "
    "fraction (0.41, not 41 %), averaged over the windows weighted by their 5 Hz cycles. "
    "Here it is taken on the held-out windows, with the calibrated LTI model (baseline) and "
    "the improved one; <code>compare</code> takes it with the rig file's nominal model over "
    "every steady segment, so its figure differs by the model and the data, not the measure. "
    "Every NRMSE on this page is this one."
)
HELD_OUT_ERROR = (
    "The <b>held-out error</b> is the diagnosis's own measure, the one its fits minimise and "
    "its hypotheses are ranked by: per channel, the RMS residual over the held-out cycles "
    "divided by the channel's peak-to-peak over all the steady segments together (NRMSE "
    "divides by each window's own, which is smaller when the segments sit at different "
    "pressures, so NRMSE reads larger), squared and averaged over the three channels; a "
    "hypothesis's \"error cut\" is the baseline's held-out error over its own."
)
OTHER_WINDOWS = (
    "A held-out window that is not pulsing (a sweep's last band, a ramp's part) is taken "
    "whole: peak-to-peak ratio, lag over the rig's period T and NRMSE over the window, "
    "weighted by its length in periods T."
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
    """Write ``report.html`` (its figures inside it) into ``out``; return the page's path.

    Args:
        diagnosis: what :func:`~brake_hil.diagnosis.diagnose.diagnose` found.
        out: the folder (made if missing).
        rig_path: the nominal rig file the diagnosis used, named on the page.
    """
    out.mkdir(parents=True, exist_ok=True)
    page = output_file(out, "report.html")
    page.write_text(_html(diagnosis, out, rig_path), encoding="utf-8")
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


_PERCENT = r"(\d+(?:\.\d+)?) %"


def nrmse_as_fraction(text: str) -> str:
    """The diagnosis's words with every NRMSE on one scale, a fraction as ``compare`` prints.

    ``14.16 % NRMSE`` -> ``NRMSE 0.1416``; ``NRMSE 14.16 % -> 2.10 %`` -> ``NRMSE 0.1416 ->
    0.0210``; ``NRMSE at most 0.80 %`` -> ``NRMSE at most 0.0080``.
    """

    def fraction(match: re.Match[str]) -> str:
        return f"{float(match.group(0).split()[0]) / 100:.4f}"

    text = re.sub(_PERCENT + " NRMSE", lambda m: f"NRMSE {fraction(m)}", text)
    return re.sub(
        r"(NRMSE(?: at most)? )" + _PERCENT + r"(?: -> " + _PERCENT + ")?",
        lambda m: (
            m.group(1)
            + f"{float(m.group(2)) / 100:.4f}"
            + (f" -> {float(m.group(3)) / 100:.4f}" if m.group(3) else "")
        ),
        text,
    )


def _confidence_words(diagnosis: Diagnosis, doubt: str | None = None) -> str:
    """How sure, in words: high, moderate or low, its figure, and a rule's doubt.

    The figure is how often verdicts like this one were right (:mod:`.reliability`).
    """
    figure = f"confidence {diagnosis.confidence:.2f}: how often verdicts like this one were right"
    strength = _strength(diagnosis.confidence)
    if diagnosis.confidence_capped is not None:
        return (
            f"{strength} ({figure}), {html.escape(diagnosis.confidence_capped)} "
            "(what to check, below)"
        )
    if strength == "high":
        return f"high ({figure})"
    if doubt is not None:
        return f"{strength}, not sure it is alone ({figure}; what to check, below)"
    if strength == "low":
        return f"low ({figure}): treat the verdict as a hint, not a finding"
    rival = runner_up(diagnosis.summary, tuple(diagnosis.effects))
    other = f"{html.escape(rival[0])}, at {rival[1]:.2f}, " if rival else ""
    return (
        f"moderate ({figure}): check the runner-up, {other}the next hypothesis by its "
        "share of the posterior, in the hypotheses table"
    )


def _strength(confidence: float) -> str:
    """high, moderate or low, as the report's "How sure" says it."""
    return "high" if confidence >= 0.9 else "moderate" if confidence >= 0.5 else "low"


def _nrmse(value: float) -> str:
    """An NRMSE as ``compare`` prints it: a fraction, not a percentage."""
    return f"{value:.4f}"


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
            f"{_nrmse(before[worst]['nrmse'])} with the calibrated LTI model, "
            f"{_nrmse(after[worst]['nrmse'])} with the improved one "
            f"(peak-to-peak {before[worst]['ptp_ratio_pct']:.1f} % -> "
            f"{after[worst]['ptp_ratio_pct']:.1f} % of measured)."
        )
    elif "unexplained" in diagnosis.effects:
        items.append(
            "<b>What was wrong:</b> the LTI model misses the recording by more than its noise, "
            f"and none of the {len(CANDIDATES)} candidate physics explains it "
            f"({worst} NRMSE {_nrmse(before[worst]['nrmse'])}). Something outside the "
            "library: look at the sensors' calibration and the rig's build."
        )
    elif diagnosis.rig_values:
        items.append(
            f"<b>What was wrong:</b> {_text(rig_values_text(diagnosis.rig_values))}; no "
            "missing physics: the calibrated LTI model explains the recording with it "
            f"(worst channel {worst}, NRMSE {_nrmse(before[worst]['nrmse'])})."
        )
    else:
        items.append(
            "<b>What was wrong:</b> nothing the data can show: the calibrated LTI model "
            f"explains the recording (worst channel {worst}, NRMSE "
            f"{_nrmse(before[worst]['nrmse'])})."
        )
    doubt = diagnosis.summary.doubt(tuple(effects)) if effects else None
    items.append(f"<b>How sure:</b> {_confidence_words(diagnosis, doubt)}.")
    checks = _rig_checks(diagnosis, findings)
    if checks:
        listed = "".join(f"<li>{c}</li>" for c in checks)
        items.append(f"<b>What to check on the rig:</b><ul>{listed}</ul>")
    else:
        items.append("<b>What to check on the rig:</b> nothing stands out.")
    return "<ul class=summary>" + "".join(f"<li>{i}</li>" for i in items) + "</ul>"


def _rig_checks(diagnosis: Diagnosis, findings: list[Finding]) -> list[str]:
    """What to check on the rig (HTML items): effects, doubt, rig file, outputs held."""
    effects = tuple(e for e in diagnosis.effects if e in CATALOGUE)
    doubt = diagnosis.summary.doubt(effects) if effects else None
    air = diagnosis.air
    checks = [
        f"the air: {air['text']}" if e == "entrained_air" and air is not None else RIG_CHECKS[e]
        for e in effects
        if e in RIG_CHECKS
    ]
    if air is not None and "entrained_air" not in effects:
        checks.append(f"the air: {air['text']}")
    checks += [f"what else is there: {doubt}"] if doubt is not None else []
    tie = tied_with(diagnosis.summary, effects, diagnosis.confidence_capped)
    others = tie[0].split(" and ") if tie is not None else []
    checks += [f"not told apart from it: {RIG_CHECKS[e]}" for e in others if e in RIG_CHECKS]
    named = {str(v["quantity"]) for v in diagnosis.rig_values}
    checks += [f"a rig value far outside its tolerance: {v['text']}" for v in diagnosis.rig_values]
    checks += [f.words for f in findings if f.name not in named]
    checks += held_sentences(diagnosis.dataset.held)
    return [_text(c) for c in checks]


def _evidence(diagnosis: Diagnosis) -> str:
    """The evidence's lines; its residual and noise lines in plain words."""
    values = diagnosis.evidence.values
    steady = diagnosis.dataset.steady  # else: over its windows, the noise above 150 Hz
    over = "the steady cycles" if steady else "its windows"
    noise = "cycle-to-cycle" if steady else "raw channels' (above 150 Hz)"
    whole = "all the steady segments" if steady else "all its windows"
    items = []
    for line in diagnosis.evidence.findings:
        if line.startswith("measurement noise") and "misfit_over_noise" in values:
            line = (
                f"{noise_words(values['misfit_over_noise'])}: the calibrated LTI model's RMS "
                f"error over {over}, against the {noise} sensor noise "
                f"({100 * values.get('noise_nrmse', math.nan):.3f} % of peak-to-peak)"
            )
        elif line.startswith("calibrated LTI baseline's RMS residual"):
            shown = [k for k in OUTPUT_CHANNELS if f"held_out_rms_{k}" in values]
            errors = ", ".join(f"{k} {values[f'held_out_rms_{k}']:.4f}" for k in shown)
            tail = line[line.index(";") :] if ";" in line else ""
            line = (
                f"calibrated LTI model's RMS residual over {over}, as a fraction of "
                f"the peak-to-peak over {whole} (the held-out error's scale, "
                f"not NRMSE's): {errors}{tail.replace('above 1 %', 'above 0.01')}"
            )
        items.append(f"<li>{_text(line)}</li>")
    return "<ul>" + "".join(items) + "</ul>"


# --------------------------------------------------------------------------- tables


def _metrics_table(diagnosis: Diagnosis) -> str:
    rows = []
    for key in OUTPUT_CHANNELS:
        b = diagnosis.baseline_metrics[key]
        i = diagnosis.improved_metrics[key]
        rows.append(
            f"<tr><td>{key}</td><td>{b['ptp_ratio_pct']:.1f}</td><td>{i['ptp_ratio_pct']:.1f}</td>"
            f"<td>{b['tau_over_T_pct']:+.2f}</td><td>{i['tau_over_T_pct']:+.2f}</td>"
            f"<td>{_nrmse(b['nrmse'])}</td><td>{_nrmse(i['nrmse'])}</td></tr>"
        )
    other = "" if diagnosis.dataset.steady else f"<p>{OTHER_WINDOWS}</p>"
    return (
        f"<p>{NRMSE_DEFINITION}</p><p>{HELD_OUT_ERROR}</p>{other}"
        "<table><tr><th>channel</th><th>ptp % baseline</th><th>ptp % improved</th>"
        "<th>tau/T % baseline</th><th>tau/T % improved</th><th>NRMSE baseline</th>"
        "<th>NRMSE improved</th></tr>" + "".join(rows) + "</table>"
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
        is_verdict = fit.effects == chosen
        mark = ' class="verdict"' if is_verdict else ""
        flag = " <span class=flag>&#9664; the verdict</span>" if is_verdict else ""
        rows.append(
            f"<tr{mark}><td>{' + '.join(fit.effects)}{flag}</td>"
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
    place = next((n for n, h in enumerate(ranked, start=1) if h.effects == chosen), None)
    where = (
        f"The verdict is marked (row {place} of {len(ranked)}). "
        if place is not None
        else "No row is the verdict: no hypothesis was named. "
    )
    order = (
        f"<p class=order>{where}Rows are in order of the held-out error cut, largest first: "
        "how much each hypothesis's model cuts the held-out error. The verdict is not always "
        "the top row: a hypothesis is named only when it also passes the decision's rules "
        "(the pair rule, the charge per fitted parameter, the physics checks below); the "
        "decision column says why each row is or is not the verdict.</p>"
    )
    return (
        f"{order}{lead}<table><tr><th>hypothesis</th><th>held-out error cut (x)</th>"
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
            f"<td>{_multiplier_words(before, z_before)}</td>"
            f"<td>{_multiplier_words(after, z_after)}</td>"
            f"<td>{words}</td></tr>"
        )
    return (
        "<p>Each value as the data put it, over the rig file's value (1: the file is right), "
        "and how many of the tolerances the rig file states it sits from it, fitted with the "
        f"LTI model alone and with the verdict's physics. At {FLAG_SIGMA:g} tolerances or "
        "more with the verdict's physics, the rig file's value is itself a finding.</p>"
        "<table><tr><th>value</th><th>LTI model alone</th><th>with the verdict's physics"
        "</th><th>finding</th></tr>" + "".join(rows) + "</table>"
    )


def _multiplier_words(multiplier: float, tolerances: float) -> str:
    """``0.024 of the file's value, 7.5 tolerances below`` (not ``x0.024 (-7.5)``)."""
    if abs(tolerances) < 0.05:
        where = "at the file's value"
    else:
        side = "below" if tolerances < 0 else "above"
        where = f"{abs(tolerances):.1f} tolerance{'' if abs(tolerances) == 1 else 's'} {side}"
    return f"{multiplier:.3f} of the file's value, {where}"


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


def _figures(diagnosis: Diagnosis) -> str:
    shown = figures(diagnosis).shown
    return "".join(image(uri, alt, caption) for uri, alt, caption in shown)


def _html(diagnosis: Diagnosis, out: Path, rig_path: Path | None) -> str:
    verdict = ", ".join(diagnosis.effects) or "no missing physics"
    findings = calibration_findings(diagnosis)
    ds = diagnosis.dataset
    length = float(ds.time[-1] - ds.time[0] + ds.sample_time)
    when = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    rig = html.escape(str(rig_path)) if rig_path is not None else "not given"
    named = bool(diagnosis.effects) and diagnosis.effects != ("unexplained",)
    off = [_text(str(v["text"])) for v in diagnosis.rig_values]
    checks = _rig_checks(diagnosis, findings)
    steps = next_steps(diagnosis.recording, out, rig_path, named, checks, off)
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>brake_hil diagnosis: {html.escape(verdict)}</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:auto;line-height:1.4}}
td,th{{border:1px solid #ccc;padding:3px 8px;vertical-align:top}}
table{{border-collapse:collapse}}tr.verdict{{background:#e8f4e8;font-weight:bold}}
.flag{{color:#1a7f37;white-space:nowrap}}p.why{{background:#fff6e0;padding:6px}}
ul.summary li{{margin:4px 0}}figure{{margin:12px 0}}figcaption{{color:#333}}
pre{{background:#f4f4f4;padding:6px;overflow-x:auto}}.meta{{color:#444}}</style>
</head><body>
<h1>Diagnosis: {html.escape(verdict)}</h1>
<p class=meta><b>Recording:</b> {html.escape(diagnosis.recording)} ({length:.1f} s)<br>
<b>Rig file:</b> {rig}<br>
<b>Made:</b> {when} by brake_hil {__version__}</p>
<h2>In short</h2>
{_summary(diagnosis, findings)}
<p>{_text(nrmse_as_fraction(diagnosis.explanation))}</p>
<h2>The paper's metrics on held-out data (Tables 4-5)</h2>{_metrics_table(diagnosis)}
{_figures(diagnosis)}
<h2>Evidence</h2>{_evidence(diagnosis)}
<h2>Calibration: is the rig file right?</h2>{_calibration_table(diagnosis, findings)}
<h2>Hypotheses (held-out error cut: the baseline's held-out error over the hypothesis's)</h2>
{_hypotheses_table(diagnosis)}
<h2>Physics checks</h2>{_checks_table(diagnosis)}
{_forms_table(diagnosis)}
{steps}
</body></html>
"""
