"""The result of a diagnosis (:class:`Diagnosis`), its JSON and its explanation in words.

:meth:`Diagnosis.as_dict` is docs/interface.md's ``diagnosis.json`` (with more keys);
:meth:`Diagnosis.improved_model` the ``improved_model.json`` the caliper-model node loads.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
import math
from pathlib import Path

from brake_hil.diagnosis.calibration import Calibration
from brake_hil.diagnosis.candidates import candidate
from brake_hil.diagnosis.dataset import Dataset
from brake_hil.diagnosis.evidence import Evidence
from brake_hil.diagnosis.fitting import Fit, Model
from brake_hil.diagnosis.groove import GrooveAsymmetry
from brake_hil.diagnosis.improved_model import ImprovedModel
from brake_hil.diagnosis.physics_checks import CheckOutcome, unidentified
from brake_hil.diagnosis.posterior import posterior
from brake_hil.diagnosis.reliability import traits
from brake_hil.diagnosis.residual_forms import ResidualDescription
from brake_hil.diagnosis.summary import Summary
from brake_hil.diagnosis.thresholds import NOISE_EXCESS
from brake_hil.diagnosis.ties import tied_with
from brake_hil.diagnosis.verdict import Verdict, confidence_text, fit_gain, fit_score
from brake_hil.words import noise_times

__all__ = ["Diagnosis", "explain"]

Metrics = dict[str, dict[str, float]]
"""The seed's Table 4-5 metrics by output channel (``ptp_ratio_pct``, ``tau_over_T_pct``,
``nrmse``)."""


@dataclass(frozen=True)
class Diagnosis:
    """The result of :func:`diagnose` (what ``diagnosis.json`` holds, plus the fits)."""

    recording: str
    effects: tuple[str, ...]
    confidence: float
    explanation: str
    evidence: Evidence
    calibration: Calibration
    baseline: Fit
    improved: Fit
    hypotheses: list[Fit]
    baseline_metrics: dict[str, dict[str, float]]
    improved_metrics: dict[str, dict[str, float]]
    dataset: Dataset
    summary: Summary
    model: Model  # the improved model as fitted and scored (the baseline's when none named)
    unfitted: tuple[str, ...] = ()  # hypotheses left out: not finite where their fit starts
    checks: dict[str, list[CheckOutcome]] = field(default_factory=dict)  # physics checks run
    residual: ResidualDescription | None = None  # what an unexplained misfit looks like
    confidence_capped: str | None = None  # Verdict.capped: a rule's doubt in words, or None
    rig_values: list[dict[str, object]] = field(default_factory=list)  # rig_findings
    air: dict[str, object] | None = None  # the air against the rig file's (rig_findings)
    groove: GrooveAsymmetry | None = None  # the seal's apply/release asymmetry (stick-slip)

    def confidence_text(self) -> str:
        """The confidence as printed: ``0.83``, or ``0.41, not sure it is alone``."""
        return confidence_text(self.confidence, self.confidence_capped)

    def improved_model(self, rig_path: Path) -> ImprovedModel:
        """The improved model in the form the caliper-model node loads."""
        model = self.model
        parameters = self.improved.parameters()
        prefix = "calibration."
        return ImprovedModel(
            rig_path=rig_path.resolve(),
            multipliers={
                k[len(prefix) :]: v for k, v in parameters.items() if k.startswith(prefix)
            },
            effects=self.improved.effects,
            parameters={k: v for k, v in parameters.items() if not k.startswith(prefix)},
            flow_amplitude=model.context.flow_amplitude,
            time_reference=model.context.time_reference,
            pressure_ceiling=model.pressure_ceiling,
        )

    def as_dict(self) -> dict[str, object]:
        """JSON of docs/interface.md's ``diagnosis.json`` (with more keys)."""
        ranked = sorted(self.hypotheses, key=lambda h: fit_score(self.baseline, h), reverse=True)
        return {
            "recording": self.recording,
            "verdict": {
                "effects": list(self.effects),
                "confidence": round(self.confidence, 3),
                **self._capped(),
                "explanation": self.explanation,
                **self._unexplained_form(),
                **self._doubt(),
                "rig_values": self.rig_values,
                **({"air": self.air} if self.air is not None else {}),
                **(
                    {"groove_asymmetry": self.groove.as_dict(self.effects)}
                    if self.groove is not None
                    else {}
                ),
            },
            **({"residual": self.residual.as_dict()} if self.residual is not None else {}),
            "mismatch": {
                "channels": self.evidence.channels,
                "windows": [list(w) for w in self.evidence.windows],
                "evidence": self.evidence.findings,
                "values": self.evidence.values,
            },
            "hypotheses": [
                {
                    "effect": "+".join(h.effects),
                    "score": round(fit_score(self.baseline, h), 4),
                    "held_out_improvement": round(fit_gain(self.baseline, h), 3),
                    "held_out_rms": h.held_out_rms,
                    "parameters": h.parameters(),
                    "units": dict(zip(h.parameter_names, h.parameter_units)),
                    "signature_seen": all(
                        candidate(e).consistent(self.evidence.values) for e in h.effects
                    ),
                    "description": " ".join(candidate(e).describe() for e in h.effects),
                }
                for h in ranked
            ],
            "calibration": {
                "multipliers": self.calibration.multipliers,
                "prior_sigma": self.calibration.sigmas,
                "posterior_sigma": self.calibration.uncertainty,
                "prior_z": self.calibration.prior_z(),
                "not_identified": list(unidentified(self.calibration)),
            },
            "baseline": {"metrics": self.baseline_metrics},
            "improved": {
                "effects": list(self.improved.effects),
                "parameters": self.improved.parameters(),
                "metrics": self.improved_metrics,
            },
            "unfitted_hypotheses": list(self.unfitted),
            "physics_checks": {
                effects: [asdict(outcome) for outcome in outcomes]
                for effects, outcomes in self.checks.items()
            },
            "decision_inputs": self.summary.as_dict(),
            "split": {
                "train": [[w.start, w.end] for w in self.dataset.train],
                "held_out": [[w.start, w.end] for w in self.dataset.held_out],
            },
        }

    def _capped(self) -> dict[str, object]:
        """``confidence_capped`` (and its words, ``confidence_cap``) when a rule doubts it.

        The confidence counts the doubt (:mod:`.reliability`); the field names are kept for
        readers of earlier files, where the doubt held the confidence under a fixed cap.
        """
        if self.confidence_capped is None:
            return {}
        return {"confidence_capped": True, "confidence_cap": self.confidence_capped}

    def _doubt(self) -> dict[str, object]:
        """The verdict's doubt, for a single that may not be alone (:meth:`Summary.doubt`).

        ``not_sure_alone``: why, in words; ``possible_second_effect``: the other effect of
        the pair that betters it (:meth:`Summary.hidden_partner`), when that is why and that
        effect passes its physics checks (its signature seen, its values physical).
        """
        doubt = self.summary.doubt(self.effects)
        if doubt is None:
            return {}
        name = self.effects[0]
        alone = len(self.effects) == 1 and name not in self.summary.not_alone
        partner = self.summary.hidden_partner(name) if alone else None
        second = (
            {"possible_second_effect": partner[0]}
            if partner is not None and partner[0] is not None
            else {}
        )
        return {"not_sure_alone": doubt, **second}

    def _unexplained_form(self) -> dict[str, object]:
        """``verdict.unexplained_form``: unexplained, and a form stands out (docs/interface.md)."""
        if self.residual is None or self.effects != ("unexplained",):
            return {}
        entry = self.residual.verdict_entry()
        return {} if entry is None else {"unexplained_form": entry}


def explain(
    summary: Summary,
    verdict: Verdict,
    fits: tuple[Fit, Fit | None, Fit],
    evidence: Evidence,
    metrics: tuple[Metrics, Metrics],
    residual: ResidualDescription,
    groove: GrooveAsymmetry | None = None,
) -> str:
    """The verdict in words, with its doubts, set-aside hypotheses and unexplained form.

    Args:
        summary: the decision's inputs.
        verdict: the decision.
        fits: the baseline, the hypothesis named (None when none is), the best single.
        evidence: where the mismatch was located.
        metrics: the baseline's and the improved model's held-out metrics.
        residual: the description of the baseline's misfit.
        groove: the seal's apply/release asymmetry, for a seal verdict (:mod:`.groove`).
    """
    baseline, chosen, best = fits
    baseline_metrics, improved_metrics = metrics
    by_value = verdict.by_rig_value
    if by_value and chosen is None:
        explanation = _as_rig_value(summary, verdict, baseline_metrics)
    elif chosen is None:
        explanation = _nothing_named(summary, verdict, baseline, best, baseline_metrics)
    else:
        explanation = _explain(baseline, chosen, evidence, baseline_metrics, improved_metrics)
        if summary.excess_ratio < NOISE_EXCESS:
            explanation += (
                f" A weak effect: the baseline misses by only "
                f"{noise_times(summary.excess_ratio)}, but {chosen.effects[0]} alone leaves "
                f"{noise_times(chosen.held_out_cost / summary.noise_cost)} and no other "
                "candidate cuts the error half as much."
            )
        if by_value:
            explanation += _beside_as_rig_value(verdict, chosen)
    if groove is not None and chosen is not None:
        explanation += f" Seal: {groove.verdict_words(chosen.effects)}"
    # a verdict carried as its rig value is not its candidate's fit, which a check may refuse
    shown = {k: v for k, v in summary.stand_ins.items() if not (by_value and k in verdict.effects)}
    tie = tied_with(summary, verdict.effects, verdict.capped)
    if tie is not None and tie[1] in shown:
        explanation += (
            f" Not told apart from {tie[0]}: {shown.pop(tie[1])}; this recording does not "
            "tell the two apart."
        )
    if shown:
        first, finding = next(iter(shown.items()))
        others = [e.replace("+", " + ") for e in list(shown)[1:]]
        also = f"; also {', '.join(others)} (the report's physics checks)" if others else ""
        explanation += (
            f" Set aside by a physics check, {first.replace('+', ' and ')}: {finding}{also}."
        )
    doubt = summary.doubt(chosen.effects) if chosen is not None else None
    if doubt is not None:
        explanation += f" Not sure it is alone: {doubt}."
    explanation += f" {_how_sure(summary, verdict)}"
    if verdict.effects == ("unexplained",):
        explanation += f" {residual.summary[0].upper()}{residual.summary[1:]}."
    return explanation


def runner_up(summary: Summary, effects: tuple[str, ...]) -> tuple[str, float] | None:
    """The hypothesis with the largest posterior share after ``effects``, in words, and it."""
    shares = posterior(summary).shares
    rival = max((e for e in shares if e != tuple(effects)), key=lambda e: shares[e], default=None)
    if rival is None:
        return None
    return (" + ".join(rival) if rival else "none (the calibrated LTI model)"), shares[rival]


def _how_sure(summary: Summary, verdict: Verdict) -> str:
    """The confidence in words: what it measures, a rule's doubt, and the runner-up."""
    t = traits(summary, verdict.effects, verdict.capped is not None, verdict.margin)
    doubt = f", {verdict.capped}" if verdict.capped is not None else ""
    factor = math.exp(t.lead)
    standing = (
        f"clearing its nearest rival or rule by a factor {factor:.2g}"
        if factor >= 1.0
        else f"short of its nearest rival or rule by a factor {1.0 / factor:.2g}"
    )
    text = (
        f"How sure: {verdict.confidence:.2f}{doubt}: how often verdicts like this one "
        f"({_KIND_WORDS[t.kind]}, {standing}{', doubted by a rule' if t.capped else ''}) "
        "were right on contract-spanning benchmark cases"
    )
    rival = runner_up(summary, tuple(verdict.effects))
    if rival is None:
        return text + "."
    return text + f"; next by the posterior, {rival[0]} at {rival[1]:.2f}."


_KIND_WORDS = {
    "none": "nothing named",
    "unexplained": "unexplained",
    "single": "one effect",
    "pair": "two effects",
}
"""A verdict's kind (:class:`.reliability.VerdictTraits`) in the explanation's words."""


def _as_rig_value(summary: Summary, verdict: Verdict, baseline_metrics: Metrics) -> str:
    """The words of an effect named as the calibrated model carries it (``AS_RIG_VALUE``)."""
    worst_nrmse = max(m["nrmse"] for m in baseline_metrics.values())
    (effect,) = verdict.effects
    return (
        f"{effect}: the calibrated LTI model reaches NRMSE at most {worst_nrmse:.4f} on the "
        f"held-out cycles ({noise_times(summary.excess_ratio)}) only by moving {effect}'s own "
        f"rig value outside its tolerance, the way {effect} moves it (the rig value below); "
        "the improved model is that calibrated model, which carries it."
    )


def _beside_as_rig_value(verdict: Verdict, chosen: Fit) -> str:
    """The words of the effect a named single's fit carries as its own rig value far off."""
    beside = [e for e in verdict.effects if e not in chosen.effects]
    return (
        f" Beside it, {' and '.join(beside)}: {chosen.effects[0]}'s model fits the recording "
        f"only by moving {beside[0]}'s own rig value outside its tolerance, the way "
        f"{beside[0]} moves it (the rig value below), and carries it so."
    )


def _nothing_named(
    summary: Summary, verdict: Verdict, baseline: Fit, best: Fit, baseline_metrics: Metrics
) -> str:
    """The words of a verdict that names no library effect (unexplained or none)."""
    # Every NRMSE in words is the paper's (Tables 4-5, per cycle), a fraction, as `compare`'s.
    worst_nrmse = max(m["nrmse"] for m in baseline_metrics.values())
    if verdict.effects:
        return (
            f"The calibrated LTI model misses the held-out cycles by up to NRMSE "
            f"{worst_nrmse:.4f}, {noise_times(summary.excess_ratio)}, and no candidate "
            f"explains it: the best, "
            f"{best.effects[0]}, cuts the error {fit_gain(baseline, best):.2f} times."
        )
    if summary.excess_ratio < NOISE_EXCESS:
        return (
            f"The calibrated LTI model explains the recording: NRMSE on the held-out cycles "
            f"at most {worst_nrmse:.4f}, {noise_times(summary.excess_ratio)} (under "
            f"{math.sqrt(NOISE_EXCESS):.1f} times: nothing left to name)."
        )
    missed = (
        f"Nothing named: the calibrated LTI model misses the held-out cycles by NRMSE at most "
        f"{worst_nrmse:.4f}, {noise_times(summary.excess_ratio)}"
    )
    gain = fit_gain(baseline, best)
    if "+".join(best.effects) in summary.stand_ins:
        return (
            f"{missed}; the candidate that cuts its error most, {best.effects[0]} ({gain:.2f} "
            "times), was set aside by a physics check (below), and no other candidate or "
            "generic form explains it."
        )
    return (
        f"{missed}, but what it leaves has no shape a candidate or a generic form explains (the "
        f"best candidate, {best.effects[0]}, cuts the error only {gain:.2f} times); an effect "
        "weaker than that leftover would not show."
    )


def _explain(
    baseline: Fit,
    chosen: Fit,
    evidence: Evidence,
    baseline_metrics: Metrics,
    improved_metrics: Metrics,
) -> str:
    """The verdict in words; NRMSE the paper's (per cycle, a fraction), as `compare`'s."""
    gain = fit_gain(baseline, chosen)
    worst = max(baseline_metrics, key=lambda k: baseline_metrics[k]["nrmse"])
    parts = [
        f"{' and '.join(chosen.effects)}: the held-out mean squared error falls "
        f"{gain:.1f} times ({worst} NRMSE on the held-out cycles "
        f"{baseline_metrics[worst]['nrmse']:.4f} with the calibrated LTI model -> "
        f"{improved_metrics[worst]['nrmse']:.4f})."
    ]
    for name in chosen.effects:
        model = candidate(name)
        seen = model.consistent(evidence.values)
        parts.append(
            f"{model.describe().split('. ')[0].replace('``', '')}. Expected signature: "
            f"{model.signature}"
            f" ({'seen in the evidence' if seen else 'not clearly seen in the evidence'})."
        )
    return " ".join(parts)
