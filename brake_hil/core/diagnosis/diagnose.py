"""Find what physics the LTI model left out of a recording, model it, and show the gain.

1. Calibrate the LTI baseline within the rig file's tolerances (:mod:`.calibration`).
2. Locate the mismatch (:mod:`.evidence`).
3. Fit every candidate on the training windows, score it on the held-out windows; the best
   single candidate is kept when it cuts the held-out error by ``ACCEPT_RATIO``; a second
   effect joins it when the pair cuts the error again by ``PAIR_RATIO``.
4. Report the verdict with a confidence, the hypotheses, and the seed's metrics of the
   baseline and the improved model on the held-out data.

Nothing here reads labels, file names or metadata: only the recording's samples and the rig
file the test engineer wrote.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
import math
from pathlib import Path

import numpy as np

from brake_hil.core import signals
from brake_hil.core.characterization import characterize
from brake_hil.core.diagnosis.calibration import Calibration, calibrate
from brake_hil.core.diagnosis.candidates import BY_NAME, CANDIDATES
from brake_hil.core.diagnosis.dataset import Dataset, prepare
from brake_hil.core.diagnosis.evidence import Evidence, collect
from brake_hil.core.diagnosis.fitting import Fit, Model, fit
from brake_hil.core.diagnosis.improved_model import ImprovedModel
from brake_hil.core.recording import Recording
from brake_hil.core.rig import Rig
from brake_hil.errors import BrakeHilError
from brake_hil.topics import OUTPUT_CHANNELS

ACCEPT_RATIO = 2.0
"""A candidate must cut the held-out mean squared error at least this much."""
PAIR_RATIO = 1.8
"""A second effect must cut it again at least this much ..."""
SECOND_ALONE_RATIO = 1.3
"""... and cut the baseline's error at least this much on its own."""
PARAMETER_PENALTY = 0.05
"""Log-ratio charged per fitted parameter when ranking (prefers the simpler of equals)."""
UNEXPLAINED_NRMSE = 0.005
"""A held-out baseline NRMSE above this with no candidate accepted is 'unexplained'. The
calibrated baseline of a recording with a parameter error only misses by about 0.1 % (noise
and the virtual rig's richer line); 0.5 % is five times that."""
UNEXPLAINED_SCALE = 0.0015
"""NRMSE distance from UNEXPLAINED_NRMSE that makes the none/unexplained call confident."""
PAIR_SHORTLIST = 3


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

    def improved_model(self, rig_path: Path) -> ImprovedModel:
        """The improved model in the form the caliper-model node loads."""
        model = Model(self.calibration, [BY_NAME[e] for e in self.improved.effects], self.dataset)
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
        """JSON of interface.md's ``diagnosis.json`` (with more keys)."""
        ranked = sorted(self.hypotheses, key=lambda h: _score(self.baseline, h), reverse=True)
        return {
            "recording": self.recording,
            "verdict": {
                "effects": list(self.effects),
                "confidence": round(self.confidence, 3),
                "explanation": self.explanation,
            },
            "mismatch": {
                "channels": self.evidence.channels,
                "windows": [list(w) for w in self.evidence.windows],
                "evidence": self.evidence.findings,
                "values": self.evidence.values,
            },
            "hypotheses": [
                {
                    "effect": "+".join(h.effects),
                    "score": round(_score(self.baseline, h), 4),
                    "held_out_improvement": round(
                        self.baseline.held_out_cost / max(h.held_out_cost, 1e-15), 3
                    ),
                    "held_out_nrmse": h.held_out_nrmse,
                    "parameters": h.parameters(),
                    "units": dict(zip(h.parameter_names, h.parameter_units)),
                    "signature_seen": all(
                        BY_NAME[e].consistent(self.evidence.values) for e in h.effects
                    ),
                    "description": " ".join(BY_NAME[e].describe() for e in h.effects),
                }
                for h in ranked
            ],
            "calibration": {
                "multipliers": self.calibration.multipliers,
                "prior_sigma": self.calibration.sigmas,
                "posterior_sigma": self.calibration.uncertainty,
                "prior_z": self.calibration.prior_z(),
            },
            "baseline": {"metrics": self.baseline_metrics},
            "improved": {
                "effects": list(self.improved.effects),
                "parameters": self.improved.parameters(),
                "metrics": self.improved_metrics,
            },
            "split": {
                "train": [[w.start, w.end] for w in self.dataset.train],
                "held_out": [[w.start, w.end] for w in self.dataset.held_out],
            },
        }


def _score(baseline: Fit, candidate: Fit) -> float:
    """Log held-out improvement less a charge per parameter."""
    ratio = baseline.held_out_cost / max(candidate.held_out_cost, 1e-15)
    return math.log(ratio) - PARAMETER_PENALTY * candidate.theta.size


def held_out_metrics(model: Model, theta: np.ndarray) -> dict[str, dict[str, float]]:
    """The seed's Table 4-5 metrics of a model over the held-out windows."""
    ds = model.dataset
    result: dict[str, dict[str, float]] = {}
    collected: dict[str, list[signals.ChannelMetrics]] = {k: [] for k in OUTPUT_CHANNELS}
    for window in ds.held_out:
        outputs, index = model.simulate(window, theta[None, :])
        for c, key in enumerate(OUTPUT_CHANNELS):
            collected[key].append(
                signals.cycle_metrics(
                    outputs[0, c], ds.measured[key][index], ds.time[index], ds.period
                )
            )
    for key, items in collected.items():
        weights = np.array([m.cycles for m in items], dtype=float)
        result[key] = {
            name: float(np.average([getattr(m, name) for m in items], weights=weights))
            for name in ("ptp_ratio_pct", "tau_over_T_pct", "nrmse")
        }
    return result


Progress = Callable[[str], None]


def diagnose(recording: Recording, rig: Rig, progress: Progress | None = None) -> Diagnosis:
    """Diagnose one recording against its (nominal) rig file."""
    say = progress or (lambda message: None)
    missing = [k for k, v in recording.measured().items() if v is None]
    if missing:
        raise BrakeHilError(f"{recording.path}: diagnosis needs measured {', '.join(missing)}")
    say("preparing the recording")
    dataset = prepare(recording, rig)
    say("calibrating the LTI baseline")
    calibration = calibrate(dataset, rig)
    baseline_model = Model(calibration, [], dataset)
    baseline = fit(baseline_model)
    say("locating the mismatch")
    table3 = characterize(recording, rig)
    evidence = collect(baseline_model, baseline.theta, [(s.ptp_pressure, s.k_eh) for s in table3])
    singles: list[Fit] = []
    for candidate in CANDIDATES:
        say(f"fitting {candidate.name}")
        singles.append(fit(Model(calibration, [candidate], dataset)))
    ranked = sorted(singles, key=lambda h: _score(baseline, h), reverse=True)
    hypotheses = list(singles)
    eligible = [h for h in ranked if _plausible(h)]
    chosen: Fit | None = None
    best = eligible[0] if eligible else ranked[0]
    if eligible and _gain(baseline, best) >= ACCEPT_RATIO:
        chosen = best
        own = len(best.theta) - len(calibration.sigmas)
        for other in eligible[1 : PAIR_SHORTLIST + 1]:
            names = (best.effects[0], other.effects[0])
            if _shares_physics(names) or _gain(baseline, other) < SECOND_ALONE_RATIO:
                continue
            say(f"fitting {' + '.join(names)}")
            pair_model = Model(calibration, [BY_NAME[n] for n in names], dataset)
            other_own = len(other.theta) - len(calibration.sigmas)
            start = np.concatenate([best.theta[:own], other.theta[:other_own], best.theta[own:]])
            pair = fit(pair_model, start=start)
            hypotheses.append(pair)
            if (
                len(chosen.effects) == 1
                and _plausible(pair)
                and chosen.held_out_cost / max(pair.held_out_cost, 1e-15) >= PAIR_RATIO
            ):
                chosen = pair
    baseline_nrmse = max(baseline.held_out_nrmse.values())
    if chosen is None:
        improved = baseline
        if baseline_nrmse > UNEXPLAINED_NRMSE:
            effects: tuple[str, ...] = ("unexplained",)
            explanation = (
                f"The calibrated LTI model misses the held-out data by up to "
                f"{100 * baseline_nrmse:.1f} % NRMSE and no candidate cuts that error "
                f"{ACCEPT_RATIO:g} times; the best, {best.effects[0]}, cuts it "
                f"{baseline.held_out_cost / max(best.held_out_cost, 1e-15):.2f} times."
            )
        else:
            effects = ()
            explanation = (
                f"The calibrated LTI model explains the recording: held-out NRMSE at most "
                f"{100 * baseline_nrmse:.2f} %, and no candidate cuts the error "
                f"{ACCEPT_RATIO:g} times."
            )
    else:
        improved = chosen
        effects = chosen.effects
        explanation = _explain(baseline, chosen, evidence)
    confidence = _confidence(baseline, ranked, chosen)
    say("scoring baseline and improved models on held-out data")
    improved_model = Model(calibration, [BY_NAME[e] for e in improved.effects], dataset)
    return Diagnosis(
        recording=str(recording.path),
        effects=effects,
        confidence=confidence,
        explanation=explanation,
        evidence=evidence,
        calibration=calibration,
        baseline=baseline,
        improved=improved,
        hypotheses=hypotheses,
        baseline_metrics=held_out_metrics(baseline_model, baseline.theta),
        improved_metrics=held_out_metrics(improved_model, improved.theta),
        dataset=dataset,
    )


def _gain(baseline: Fit, candidate: Fit) -> float:
    """Held-out improvement of the mean squared error over the baseline."""
    return baseline.held_out_cost / max(candidate.held_out_cost, 1e-15)


def _plausible(fit: Fit) -> bool:
    """Every effect's fitted parameters describe that physics (see Candidate.plausible)."""
    column = 0
    for name in fit.effects:
        candidate = BY_NAME[name]
        size = len(candidate.parameters)
        if not candidate.plausible(fit.theta[column : column + size]):
            return False
        column += size
    return True


def _shares_physics(names: tuple[str, str]) -> bool:
    """Pairs that are one physics twice (none among the current candidates)."""
    return names[0] == names[1]


def _explain(baseline: Fit, chosen: Fit, evidence: Evidence) -> str:
    ratio = baseline.held_out_cost / max(chosen.held_out_cost, 1e-15)
    worst = max(baseline.held_out_nrmse, key=lambda k: baseline.held_out_nrmse[k])
    parts = [
        f"{' and '.join(chosen.effects)}: the held-out mean squared error falls "
        f"{ratio:.1f} times ({worst} NRMSE {100 * baseline.held_out_nrmse[worst]:.2f} % -> "
        f"{100 * chosen.held_out_nrmse[worst]:.2f} %)."
    ]
    for name in chosen.effects:
        candidate = BY_NAME[name]
        seen = candidate.consistent(evidence.values)
        parts.append(
            f"{candidate.describe().split('. ')[0]}. Expected signature: {candidate.signature}"
            f" ({'seen in the evidence' if seen else 'not clearly seen in the evidence'})."
        )
    return " ".join(parts)


def _confidence(baseline: Fit, ranked: list[Fit], chosen: Fit | None) -> float:
    """Probability-like confidence from the margins of the decision.

    With effects: how far the winner's log-gain clears both the acceptance ratio and the
    runner-up. Without: how far the best candidate stays below acceptance, times how far
    the baseline's held-out NRMSE is from the 'unexplained' threshold (on its side).
    """
    gains = [math.log(baseline.held_out_cost / max(f.held_out_cost, 1e-15)) for f in ranked]
    if chosen is not None:
        runner_up = next(
            (g for f, g in zip(ranked, gains) if f.effects[0] != chosen.effects[0]), 0.0
        )
        margin = min(gains[0] - runner_up, gains[0] - math.log(ACCEPT_RATIO))
        return _logistic(CONFIDENCE_SLOPE * margin + CONFIDENCE_OFFSET)
    below_accept = _logistic(
        CONFIDENCE_SLOPE * (math.log(ACCEPT_RATIO) - gains[0]) + CONFIDENCE_OFFSET
    )
    distance = abs(max(baseline.held_out_nrmse.values()) - UNEXPLAINED_NRMSE)
    return below_accept * _logistic(distance / UNEXPLAINED_SCALE)


def _logistic(x: float) -> float:
    return float(1.0 / (1.0 + math.exp(-x)))


CONFIDENCE_SLOPE = 3.0
CONFIDENCE_OFFSET = 0.5
