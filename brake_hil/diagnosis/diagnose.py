"""Find what physics the LTI model left out of a recording, model it, and show the gain.

The pipeline (docs/diagnosis.md):

1. Prepare the recording: segments, training and held-out windows (:mod:`.dataset`).
2. Calibrate the LTI baseline within the rig file's tolerances (:mod:`.calibration`).
3. Locate the mismatch (:mod:`.evidence`) and describe it by generic forms
   (:mod:`.residual_forms`).
4. Fit every candidate on the training windows, score it on the held-out windows, and pairs
   of the best with the next ones (:mod:`.fitting`, :mod:`.candidates`).
5. Decide the verdict from the held-out costs (:mod:`.summary`, :mod:`.verdict`,
   thresholds in :mod:`.thresholds`), and check the physics of the hypothesis named
   (:mod:`.physics_checks`); one that fails is set aside and the next decided.
6. Report the verdict with a confidence, the hypotheses, and the seed's metrics of the
   baseline and the improved model on the held-out data (:mod:`.result`).

Nothing here reads labels, file names or metadata: only the recording's samples and the rig
file the test engineer wrote.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from brake_hil.analysis import segment_metrics, signals
from brake_hil.analysis.characterization import characterize
from brake_hil.analysis.recording import Recording
from brake_hil.analysis.saturation import Held
from brake_hil.diagnosis import segment_evidence
from brake_hil.diagnosis.calibration import Calibration, calibrate
from brake_hil.diagnosis.candidates import CANDIDATES, candidate
from brake_hil.diagnosis.dataset import Dataset, prepare
from brake_hil.diagnosis.evidence import Evidence, collect, even_harmonics_left
from brake_hil.diagnosis.fitting import Fit, Model, fit, fit_from_both
from brake_hil.diagnosis.groove import groove_asymmetry, symmetric_seals
from brake_hil.diagnosis.physics_checks import CheckOutcome, check_hypothesis
from brake_hil.diagnosis.residual_forms import (
    baseline_predictions,
    describe_residual,
)
from brake_hil.diagnosis.result import Diagnosis, Metrics, explain
from brake_hil.diagnosis.rig_findings import air_beside, for_verdict
from brake_hil.diagnosis.summary import (
    Hypothesis,
    Summary,
    own_values_beside,
    own_values_outside,
    plausible,
    ratio,
    summarise,
)
from brake_hil.diagnosis.thresholds import (
    ACCEPT_RATIO,
    CHECK_ROUNDS,
    CLEAR_ACCEPT_RATIO,
    CLEAR_EXCESS,
    FORM_RATIO,
    NOISE_EXCESS,
    PAIR_FIT_RATIO,
    PAIR_RATIO,
    PAIR_SHARE,
    PAIR_SHORTLIST,
    PARAMETER_PENALTY,
    STAND_IN_MARGIN,
    STRUCTURED_RATIO,
    UNEXPLAINED_RMS,
    WEAK_SINGLE_LEFT,
    WEAK_SINGLE_RATIO,
    WINDOW_FLOOR,
)
from brake_hil.diagnosis.verdict import (
    Verdict,
    decide,
    fit_gain,
    fit_score,
    hypothesis_note,
    identified,
    required_ratio,
    unfitted_pairs_matter,
    unnameable_pairs,
    weak_single,
)
from brake_hil.errors import BrakeHilError, FitError
from brake_hil.physics.rig import Rig
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray

__all__ = [
    "ACCEPT_RATIO",
    "CHECK_ROUNDS",
    "CLEAR_ACCEPT_RATIO",
    "CLEAR_EXCESS",
    "FORM_RATIO",
    "NOISE_EXCESS",
    "PAIR_FIT_RATIO",
    "PAIR_RATIO",
    "PAIR_SHARE",
    "PAIR_SHORTLIST",
    "PARAMETER_PENALTY",
    "STAND_IN_MARGIN",
    "STRUCTURED_RATIO",
    "UNEXPLAINED_RMS",
    "WEAK_SINGLE_LEFT",
    "WEAK_SINGLE_RATIO",
    "WINDOW_FLOOR",
    "Diagnosis",
    "Hypothesis",
    "Progress",
    "Summary",
    "Verdict",
    "decide",
    "diagnose",
    "held_out_metrics",
    "hypothesis_note",
    "identified",
    "ratio",
    "required_ratio",
    "summarise",
    "unfitted_pairs_matter",
    "unnameable_pairs",
    "weak_single",
]


def held_out_metrics(model: Model, theta: FloatArray) -> Metrics:
    """The seed's Table 4-5 metrics of a model over the held-out windows.

    Pulsing windows per cycle (:func:`signals.cycle_metrics`), weighted by their cycles;
    the others (a sweep's band, a ramp) over the window: peak-to-peak ratio, lag over the
    rig's period ``T`` (as ``compare`` scores a recording without steady pulsing) and NRMSE,
    weighted by their length in periods ``T``.
    """
    ds = model.dataset
    result: Metrics = {}
    names = ("ptp_ratio_pct", "tau_over_T_pct", "nrmse")
    collected: dict[str, list[tuple[float, ...]]] = {k: [] for k in OUTPUT_CHANNELS}
    for window in ds.held_out:
        outputs, index = model.simulate(window, theta[None, :])
        for c, key in enumerate(OUTPUT_CHANNELS):
            predicted, measured, time = outputs[0, c], ds.measured[key][index], ds.time[index]
            if window.kind in ("steady", "pulsing"):
                period = window.period or ds.period
                m = signals.cycle_metrics(predicted, measured, time, period)
                collected[key].append((m.cycles, *(getattr(m, name) for name in names)))
            else:
                collected[key].append(_span_metrics(predicted, measured, time, ds.period))
    for key, items in collected.items():
        weights = np.array([m[0] for m in items], dtype=float)
        result[key] = {
            name: float(np.average([m[1 + n] for m in items], weights=weights))
            for n, name in enumerate(names)
        }
    return result


def _span_metrics(
    predicted: FloatArray, measured: FloatArray, time: FloatArray, period: float
) -> tuple[float, float, float, float]:
    """Weight (periods), ptp ratio (%), lag over ``period`` (%) and NRMSE of a window."""
    lag = segment_metrics.lag_s(time, predicted, measured, slice(0, time.size), LAG_RANGE_S)
    return (
        (time[-1] - time[0]) / period,
        100.0 * float(np.ptp(predicted)) / max(float(np.ptp(measured)), 1e-30),
        100.0 * lag / period,
        signals.nrmse(predicted, measured),
    )


LAG_RANGE_S = 0.05
"""The longest lag (s) sought in a window that is not pulsing."""


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
    # the seed's Table 3 is of steady pulsing; the other kinds' evidence is their own
    table3 = (
        characterize(recording, rig) if any(w.kind == "steady" for w in dataset.segments) else []
    )
    evidence = collect(baseline_model, baseline.theta, [(s.ptp_pressure, s.k_eh) for s in table3])
    fits = _Fits(calibration, dataset, baseline, say)
    for single in CANDIDATES:
        say(f"fitting {single.name}")
        fits.singles.extend(fits.attempt(Model(calibration, [single], dataset), None))
    say("describing the misfit by generic forms")
    residual = describe_residual(
        dataset,
        baseline_predictions(baseline_model, baseline.theta),
        noise_cost=dataset.noise_cost(),
    )
    form_gains = {f"{f.form} {f.channel}": f.improvement for f in residual.forms}
    summary, verdict, pairs = _decide_with_pairs(fits, evidence, form_gains)
    hypotheses = fits.singles + pairs
    summary, verdict, checks = _check_physics(fits, hypotheses, summary, verdict)
    chosen = next((h for h in hypotheses if h.effects == verdict.chosen), None)
    best = max(fits.singles, key=lambda h: fit_score(baseline, h))
    improved = baseline if chosen is None else chosen
    say("scoring baseline and improved models on held-out data")
    improved_model = Model(calibration, [candidate(e) for e in improved.effects], dataset)
    metrics = (
        held_out_metrics(baseline_model, baseline.theta),
        held_out_metrics(improved_model, improved.theta),
    )
    groove = groove_asymmetry(verdict.effects, baseline, fits.singles)
    explanation = explain(
        summary, verdict, (baseline, chosen, best), evidence, metrics, residual, groove
    )
    rig_values, air, words = for_verdict(
        calibration,
        improved.parameters(),
        verdict.effects,
        float(np.mean([w.mean_pressure for w in dataset.train])),
        ground=verdict.by_rig_value,
        air_shown=summary.air_shows(verdict.effects),
    )
    explanation = _with_advice(_with_rig_values(explanation, words, verdict), verdict, dataset)
    if verdict.effects != ("unexplained",):
        # the description is of the baseline's misfit, which the verdict explains or not
        residual = residual.reworded("the calibrated LTI baseline's misfit")
    return Diagnosis(
        recording=str(recording.path),
        effects=verdict.effects,
        confidence=verdict.confidence,
        confidence_capped=verdict.capped,
        explanation=explanation,
        evidence=evidence,
        calibration=calibration,
        baseline=baseline,
        improved=improved,
        hypotheses=hypotheses,
        baseline_metrics=metrics[0],
        improved_metrics=metrics[1],
        dataset=dataset,
        summary=summary,
        model=improved_model,
        unfitted=tuple(fits.unfitted),
        checks=checks,
        residual=residual,
        rig_values=rig_values,
        air=air,
        groove=groove,
    )


def _with_rig_values(explanation: str, words: str, verdict: Verdict) -> str:
    """``explanation`` and :func:`for_verdict`'s sentence: first when nothing is named."""
    if not words:
        return explanation
    return f"{explanation} {words}" if verdict.effects else f"{words} {explanation}"


ADVICE_BELOW = 0.5
"""Below this confidence (or unexplained) the explanation names the excitations that would
tell more than the recording holds (:func:`segment_evidence.missing`)."""


def _with_advice(explanation: str, verdict: Verdict, dataset: Dataset) -> str:
    """``explanation`` with what it cannot settle: the excitations that would decide.

    Those when the verdict is unsure; then the channels held at a range's end
    (:func:`held_sentences`), always.
    """
    advice = segment_evidence.missing(dataset)
    unsure = verdict.confidence < ADVICE_BELOW or verdict.effects == ("unexplained",)
    if advice and unsure:
        explanation = (
            f"{explanation} This recording holds too little to be sure: {'; '.join(advice)}."
        )
    return " ".join([explanation, *held_sentences(dataset.held)])


HELD_UNITS = {"p_b": (1e-6, "MPa"), "F_k": (1e-3, "kN"), "x_c": (1e6, "um")}
"""How a held channel's end is said: factor from SI and unit."""


def held_sentences(held: dict[str, Held]) -> list[str]:
    """A sentence per output held at a range's end (:func:`saturation.held_limits`)."""
    sentences = []
    for key, limits in held.items():
        factor, unit = HELD_UNITS.get(key, (1.0, "SI"))
        ends = [f"{factor * v:.1f} {unit}" for v in (limits.low, limits.high) if np.isfinite(v)]
        sentences.append(
            f"{key} is held at {' and '.join(ends)} in {100 * limits.share:.1f} % of the samples "
            "diagnosed: "
            "its transducer (or the DAQ) reached the end of its range there; every model is "
            f"compared as {key} reads, cut at that end. Widen the range and test again."
        )
    return sentences


@dataclass
class _Fits:
    """What every fit of one diagnosis shares, and the singles fitted so far."""

    calibration: Calibration
    dataset: Dataset
    baseline: Fit
    say: Progress
    singles: list[Fit] = field(default_factory=list)
    unfitted: list[str] = field(default_factory=list)  # hypotheses not finite where they start

    def attempt(self, model: Model, start: FloatArray | None) -> list[Fit]:
        """The fit of ``model`` as a one-item list, or none (:func:`_try_fit`)."""
        return _try_fit(model, start, self.unfitted, self.say)

    def even_left(self) -> dict[str, tuple[float, float, float]]:
        """The even harmonics of ``p_b`` each single whose law cannot make them leaves.

        Share (%), z and power (:func:`.evidence.even_harmonics_left`), for
        :func:`.summary.unmade_signature`; a single whose run is not finite is left out.
        """
        left = {}
        for h in self.singles:
            name = h.effects[0]
            if candidate(name).even_harmonics:
                continue
            try:
                left[name] = even_harmonics_left(
                    Model(self.calibration, [candidate(name)], self.dataset), h.theta
                )
            except (FitError, FloatingPointError):
                continue
        return left

    def pairs(self, ruled_out: frozenset[tuple[str, ...]] = frozenset()) -> list[Fit]:
        """The pairs of the best single with the next ones (:func:`fit_pairs`)."""
        return fit_pairs(
            self.calibration,
            self.dataset,
            self.baseline,
            self.singles,
            self.unfitted,
            self.say,
            ruled_out,
        )


def _decide_with_pairs(
    fits: _Fits, evidence: Evidence, form_gains: dict[str, float]
) -> tuple[Summary, Verdict, list[Fit]]:
    """Fit the pairs that can be named, decide; fit the rest when they matter, decide again.

    The pairs that can never be named (:func:`unnameable_pairs`) are fitted only when one of
    them would be a rival or a partner of the verdict (:func:`unfitted_pairs_matter`); still
    unnameable, the worst case of each stays charged (the fits only add doubt).
    """
    noise_cost = fits.dataset.noise_cost()
    # a pair of a law with its own special case is no hypothesis: neither fitted nor charged
    ruled_out = frozenset(
        p for p in unnameable_pairs(fits.baseline, fits.singles) if not _nested(*p)
    )
    pairs = fits.pairs(ruled_out)
    left = fits.even_left()
    mean_pressure = float(np.mean([w.mean_pressure for w in fits.dataset.train]))

    def summary_of(pairs: list[Fit]) -> Summary:
        air = air_beside(fits.calibration, fits.singles, pairs, mean_pressure)
        return summarise(
            fits.baseline,
            fits.singles,
            pairs,
            noise_cost,
            evidence,
            ruled_out,
            form_gains,
            left,
            air,
            fits.dataset.steady,
            own_values_outside(fits.calibration),
            own_values_beside(fits.calibration, fits.singles),
        )

    summary = summary_of(pairs)
    verdict = decide(summary)
    if unfitted_pairs_matter(summary, verdict):
        fits.say("fitting the pairs left out, as rivals or partners of the verdict")
        pairs = fits.pairs()
        summary = summary_of(pairs)
        verdict = decide(summary)
    return summary, verdict, pairs


def _check_physics(
    fits: _Fits, hypotheses: list[Fit], summary: Summary, verdict: Verdict
) -> tuple[Summary, Verdict, dict[str, list[CheckOutcome]]]:
    """Check the physics of the hypothesis named; one that fails is set aside, decide again.

    At most ``CHECK_ROUNDS`` hypotheses are checked; the checks run, by hypothesis.
    """
    checks: dict[str, list[CheckOutcome]] = {}
    rounds = 0
    while rounds < CHECK_ROUNDS:
        named = next((h for h in hypotheses if h.effects == verdict.chosen), None)
        if named is None or "+".join(named.effects) in checks:
            break
        key = "+".join(named.effects)
        fits.say(f"checking the physics of {key}")
        checks[key] = check_hypothesis(
            fits.calibration,
            fits.dataset,
            fits.baseline,
            named,
            required_ratio(summary),
            symmetric_seals(fits.baseline, fits.singles, hypotheses, named.effects),
        )
        failed = next((c for c in checks[key] if not c.passed), None)
        if failed is None:
            break
        # the groove's asymmetry is read off its fit, and a law that holds one set aside
        # already (the groove holds stick-slip) is that hypothesis checked again: no round
        failed_before = [k.split("+") for k in checks if k != key]
        again = any(_holds_all(named.effects, tuple(k)) for k in failed_before)
        rounds += failed.name != "asymmetry" and not again
        tied = {key: failed.stands_for} if failed.stands_for else {}
        summary = replace(
            summary,
            stand_ins={**summary.stand_ins, key: failed.finding},
            not_told_from={**summary.not_told_from, **tied},
        )
        verdict = decide(summary)
    return summary, verdict, checks


def _try_fit(
    model: Model, start: np.ndarray | None, unfitted: list[str], say: Progress
) -> list[Fit]:
    """The fit of ``model`` as a one-item list; none when its simulation is not finite.

    A hypothesis that cannot be simulated is left out of the decision and named in
    ``unfitted`` (``diagnosis.json``: ``unfitted_hypotheses``), never a crash of the whole
    diagnosis.
    """
    try:
        return [fit(model, start=start) if start is not None else fit_from_both(model)]
    except FitError as error:
        unfitted.append("+".join(model.names))
        say(f"left out: {error}")
        return []


def _holds_all(effects: tuple[str, ...], earlier: tuple[str, ...]) -> bool:
    """``effects`` is ``earlier`` with some of them replaced by laws that hold them."""
    return (
        len(effects) == len(earlier)
        and set(effects) != set(earlier)
        and all(any(e == f or f in candidate(e).contains for e in effects) for f in earlier)
    )


def _nested(first: str, second: str) -> bool:
    """One of the two holds the other as a special case (``Candidate.contains``)."""
    return second in candidate(first).contains or first in candidate(second).contains


def fit_pairs(
    calibration: Calibration,
    dataset: Dataset,
    baseline: Fit,
    singles: list[Fit],
    unfitted: list[str],
    say: Progress,
    ruled_out: frozenset[tuple[str, ...]] = frozenset(),
) -> list[Fit]:
    """Pairs of the best plausible single with the next ``PAIR_SHORTLIST`` plausible ones.

    Fitted whenever the best single cuts the error at least ``PAIR_FIT_RATIO`` times (the
    decision then weighs them), starting from both singles' fitted parameters; the pairs in
    ``ruled_out`` are left out (:func:`unnameable_pairs`).
    """
    eligible = sorted(
        (h for h in singles if plausible(h)), key=lambda h: fit_score(baseline, h), reverse=True
    )
    if not eligible or fit_gain(baseline, eligible[0]) < PAIR_FIT_RATIO:
        return []
    best = eligible[0]
    by_name = {h.effects[0]: h for h in singles}
    pairs: list[Fit] = []
    for other in eligible[1 : PAIR_SHORTLIST + 1]:
        names = (best.effects[0], other.effects[0])
        if names in ruled_out or _nested(*names):
            continue
        for twin in (names, *_simpler_twins(names)):
            if twin in ruled_out or any(h.effects == twin for h in pairs):
                continue
            if not all(n in by_name for n in twin):
                continue
            say(f"fitting {' + '.join(twin)}")
            own = [by_name[n].theta[: -len(calibration.sigmas) or None] for n in twin]
            shared = by_name[twin[0]].theta[len(own[0]) :]
            model = Model(calibration, [candidate(n) for n in twin], dataset)
            pairs.extend(_try_fit(model, np.concatenate([*own, shared]), unfitted, say))
    return pairs


def _simpler_twins(names: tuple[str, ...]) -> list[tuple[str, ...]]:
    """``names`` with one law replaced by a special case it holds (the groove by stick-slip).

    The pair of the simpler law is fitted beside the pair of the law that holds it, so the
    groove's asymmetry is judged against a symmetric seal in the same company.
    """
    return [
        (*names[:i], simpler, *names[i + 1 :])
        for i, name in enumerate(names)
        for simpler in sorted(candidate(name).contains)
        if simpler not in names
    ]
