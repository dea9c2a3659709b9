"""The verdict: which effects a :class:`.summary.Summary` names, and how sure (pure; replayable).

The rules, their thresholds (:mod:`.thresholds`) and the evidence behind them:
docs/diagnosis.md.
"""

from __future__ import annotations

from dataclasses import dataclass
import math

from brake_hil.diagnosis.fitting import Fit
from brake_hil.diagnosis.reliability import holds, reliability, traits
from brake_hil.diagnosis.summary import Hypothesis, Summary, plausible, ratio
from brake_hil.diagnosis.thresholds import (
    ACCEPT_RATIO,
    CLEAR_ACCEPT_RATIO,
    CLEAR_EXCESS,
    FORM_RATIO,
    NOISE_EXCESS,
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
from brake_hil.diagnosis.ties import untie
from brake_hil.diagnosis.verdict_record import (
    AS_RIG_VALUE,
    CAME_CLOSE,
    MAY_HIDE,
    NOT_ALONE,
    OFF_PULSING,
    SET_ASIDE,
    Verdict,
    confidence_text,
)

__all__ = [
    "CAME_CLOSE",
    "NOT_ALONE",
    "MAY_HIDE",
    "OFF_PULSING",
    "SET_ASIDE",
    "Verdict",
    "confidence_text",
    "decide",
    "decide_effects",
    "fit_gain",
    "fit_score",
    "hypothesis_note",
    "identified",
    "required_ratio",
    "unfitted_pairs_matter",
    "unnameable_pairs",
    "weak_single",
]


def fit_gain(baseline: Fit, fitted: Fit) -> float:
    """Held-out improvement of the mean squared error over the baseline."""
    return ratio(baseline.held_out_cost, fitted.held_out_cost)


def fit_score(baseline: Fit, fitted: Fit) -> float:
    """Log held-out improvement less a charge per parameter."""
    return math.log(fit_gain(baseline, fitted)) - PARAMETER_PENALTY * fitted.theta.size


def _ranked_plausible(baseline: Fit, singles: list[Fit]) -> list[Fit]:
    """The plausible singles, best score first."""
    return sorted(
        (h for h in singles if plausible(h)), key=lambda h: fit_score(baseline, h), reverse=True
    )


def unnameable_pairs(baseline: Fit, singles: list[Fit]) -> frozenset[tuple[str, ...]]:
    """The pairs :func:`.diagnose.fit_pairs` would fit that :func:`decide` can never name.

    A pair is named only if it cuts the held-out error of the better of its two singles by
    ``PAIR_SHARE`` of the baseline's; no fit has a negative error, so a pair whose better
    single already leaves less than that share cannot be named, whatever its fit. Fitting it
    could change the verdict's confidence only (its posterior share); unfitted
    (:attr:`Summary.pairs_ruled_out`), they have no share, and they are fitted when
    :func:`unfitted_pairs_matter`.
    """
    eligible = _ranked_plausible(baseline, singles)
    if not eligible:
        return frozenset()
    best, limit = eligible[0], PAIR_SHARE * baseline.held_out_cost
    return frozenset(
        (best.effects[0], other.effects[0])
        for other in eligible[1 : PAIR_SHORTLIST + 1]
        if min(best.held_out_cost, other.held_out_cost) < limit
    )


def unfitted_pairs_matter(summary: Summary, verdict: Verdict) -> bool:
    """Whether the pairs left unfitted (:attr:`Summary.pairs_ruled_out`) must be fitted.

    One of them would be a rival of the verdict (it shares no effect with it), or the
    verdict is a single that leaves more than ``NOISE_EXCESS`` times the noise's share and
    a pair with it may show a second effect under it (:meth:`Summary.hidden_partner`).
    """
    chosen = verdict.chosen or ()
    fitted = {p.effects for p in summary.pairs}
    unfitted = [p for p in summary.pairs_ruled_out if p not in fitted]
    if chosen and any(not set(chosen) & set(p) for p in unfitted):
        return True
    return (
        len(chosen) == 1
        and summary.leaves_beyond_noise(chosen[0])
        and any(chosen[0] in p for p in unfitted)
    )


def hypothesis_note(summary: Summary, effects: tuple[str, ...], verdict: Verdict) -> str:
    """Why hypothesis ``effects`` is or is not ``verdict``, in one line, by :func:`decide`'s rules.

    One sentence: the verdict, an effect of it carried as a rig value (``AS_RIG_VALUE``), or
    the first rule it fails (implausible values, the pair rule, the acceptance ratio, a
    held-out window made worse, the generic form's bar, the parameter penalty).
    """
    base = summary.baseline_cost
    known = {h.effects: h for h in (*summary.singles, *summary.pairs)}
    h = known.get(effects)
    if h is None and effects in summary.pairs_ruled_out:
        return (
            f"not fitted: cannot be named (its better single leaves under "
            f"{100 * PAIR_SHARE:g} % of the baseline's error for a second effect to explain)"
        )
    if h is None:
        return "not fitted"
    if verdict.chosen == effects:
        return "the verdict"
    if verdict.by_rig_value and set(effects) <= set(verdict.effects):
        return (
            "named, as the fitted model carries it: its own rig value outside its tolerance "
            "(this fit of it is not the improved model)"
        )
    gain = ratio(base, h.held_out_cost)
    if summary.excess_ratio < NOISE_EXCESS:
        return (
            f"not named: the baseline is within {NOISE_EXCESS:g} times the noise's share; "
            f"there only a single that cuts the error {WEAK_SINGLE_RATIO:g} times, leaves "
            f"under {WEAK_SINGLE_LEFT:g} times the noise and twice beats every other is named"
        )
    if not h.plausible:
        return "not named: its fitted values describe a stand-in, not this physics"
    if "+".join(effects) in summary.stand_ins:
        return f"not named (physics check): {summary.stand_ins['+'.join(effects)]}"
    if len(effects) > 1:
        members = [known[(e,)] for e in effects if (e,) in known]
        better = min(members, key=lambda m: m.held_out_cost, default=None)
        better_cost = better.held_out_cost if better is not None else base
        again = ratio(better_cost, h.held_out_cost)
        share = (better_cost - h.held_out_cost) / base
        if again < PAIR_RATIO or share < PAIR_SHARE:
            name = better.effects[0] if better is not None else "the baseline"
            return (
                f"not named (pair rule): a second effect must cut the error of {name} alone "
                f"{PAIR_RATIO:g} times again and by {100 * PAIR_SHARE:g} % of the baseline's; "
                f"this pair cuts it {again:.2f} times, by {100 * share:.1f} %"
            )
    required = required_ratio(summary)
    if gain < required:
        return f"not named: cuts the error {gain:.2f} times, under the {required:g} required"
    if not all(
        ratio(b, w) >= WINDOW_FLOOR for b, w in zip(summary.baseline_window_costs, h.window_costs)
    ):
        return (
            f"not named: makes a held-out window more than {1 / WINDOW_FLOOR:g} times worse "
            "than the baseline (missing physics is missing everywhere)"
        )
    if not identified(summary, h):
        return (
            f"not named: cuts the error {gain:.2f} times, no more than {FORM_RATIO:g} times "
            f"what a generic form of the misfit does ({summary.form_bar(h.effects):.2f}): "
            "not identified"
        )
    chosen = known.get(verdict.chosen) if verdict.chosen is not None else None
    if chosen is not None:
        mine = math.log(gain) - PARAMETER_PENALTY * h.parameters
        theirs = (
            math.log(ratio(base, chosen.held_out_cost)) - PARAMETER_PENALTY * chosen.parameters
        )
        if mine <= theirs:
            return (
                f"not named (parameter penalty): {h.parameters} fitted parameters against "
                f"{chosen.parameters}, each costing {PARAMETER_PENALTY:g} of log-gain; its "
                f"score {mine:.2f} is below the verdict's {theirs:.2f}"
            )
    return "admissible, ranked below the verdict"


def decide(summary: Summary) -> Verdict:
    """The verdict of :func:`decide_effects`'s rules, sure as verdicts like it were right.

    Its confidence is :func:`.reliability.reliability` of its traits (its kind, its lead
    over the best rival, whether a rule doubts it: ``capped``, said in words beside the
    number): a probability fitted on one family of cases and judged on the others.
    """
    return decide_effects(summary)


def _verdict(
    summary: Summary,
    effects: tuple[str, ...],
    chosen: tuple[str, ...] | None,
    margin: float,
    capped: str | None = None,
) -> Verdict:
    """A verdict of the rules with its confidence (:mod:`.reliability`).

    On a recording that is not steady pulsing alone, a verdict no rule doubts is doubted
    as off the confidence's ground (``OFF_PULSING``).
    """
    if capped is None and not summary.steady:
        capped = OFF_PULSING
    sure = reliability(traits(summary, effects, capped is not None, margin))
    return Verdict(effects, sure, chosen, margin, capped)


def decide_effects(summary: Summary) -> Verdict:
    """Name the effects from the fitted hypotheses' held-out costs (pure; replayable).

    Admissible are the plausible singles, and the plausible pairs that cut the error of the
    better of their two singles again ``PAIR_RATIO`` times (a second effect must earn its
    place). The admissible hypothesis of best score (log held-out gain less
    ``PARAMETER_PENALTY`` per parameter) is the verdict when it cuts the baseline's held-out
    error ``ACCEPT_RATIO`` times and no held-out window gets worse than ``WINDOW_FLOOR``
    times the baseline's (a missing physics is missing everywhere; a stand-in for a
    parameter error helps one segment and hurts another), and ``FORM_RATIO`` times more than
    the best generic form of the misfit. Otherwise: ``unexplained`` when the baseline's
    held-out RMS exceeds ``UNEXPLAINED_RMS``, a generic form cuts its error
    ``STRUCTURED_RATIO`` times, or a hypothesis passed all but the generic form's bar (a
    real misfit the library does not identify), else none. While the baseline is within
    ``NOISE_EXCESS`` times the noise's share (:attr:`Summary.floor_cost`) only a weak single
    that explains it all is named (:func:`weak_single`), else nothing. A none whose
    calibrated model carries an effect's own rig value outside its tolerance, that effect's
    way (:attr:`Summary.own_values_outside`), names that effect (:func:`as_rig_value`); a
    single whose fit carries another effect's so (:attr:`Summary.own_values_beside`) is
    named with it (:func:`with_rig_value`). A hypothesis a rival ties with: :func:`.ties.untie`.
    """
    verdict = _by_the_rules(summary)
    if verdict.effects == () and summary.own_values_outside:
        verdict = as_rig_value(summary, summary.own_values_outside[0])
    elif len(verdict.effects) == 1 and summary.own_values_beside.get(verdict.effects[0]):
        verdict = with_rig_value(summary, verdict)
    return untie(summary, verdict, decide_effects)


def _by_the_rules(summary: Summary) -> Verdict:
    """:func:`decide_effects`' verdict of the held-out cuts."""
    if summary.excess_ratio < NOISE_EXCESS:
        weak = weak_single(summary)
        if weak is not None:
            return weak
        margin = math.log(NOISE_EXCESS / max(summary.excess_ratio, 1e-9))
        return _verdict(summary, (), None, margin)
    standing = _Standing.of(summary)
    cap = _caps(summary, standing)
    if standing.chosen is not None:
        return _named(summary, standing, standing.chosen, cap)
    return _not_named(summary, standing, cap)


def as_rig_value(summary: Summary, effect: str) -> Verdict:
    """``effect`` as the calibrated model (improved, ``chosen`` None, unchecked) carries it."""
    return _verdict(summary, (effect,), None, 0.0, AS_RIG_VALUE)


def with_rig_value(summary: Summary, single: Verdict) -> Verdict:
    """``single`` and the effect its fit (still improved model, checked) carries far off."""
    pair = (*single.effects, summary.own_values_beside[single.effects[0]][0])
    return _verdict(summary, pair, single.chosen, min(single.margin, 0.0), AS_RIG_VALUE)


@dataclass(frozen=True)
class _Standing:
    """The hypotheses as :func:`decide`'s rules sort them."""

    required: float  # the held-out improvement a hypothesis must reach (required_ratio)
    ranked: list[Hypothesis]  # every hypothesis, best score first
    eligible: list[Hypothesis]  # the admissible ones (plausible; a pair that earns its place)
    passing: list[Hypothesis]  # ... that reach ``required`` in every held-out window
    chosen: Hypothesis | None  # the first passing one identified (beats the generic forms)
    log_gains: dict[tuple[str, ...], float]  # log held-out improvement of every hypothesis

    @staticmethod
    def of(summary: Summary) -> _Standing:
        """Rank, admit and pass the hypotheses of ``summary``."""
        required = required_ratio(summary)
        ranked = sorted(
            (*summary.singles, *summary.pairs), key=lambda h: _score(summary, h), reverse=True
        )
        eligible = [h for h in ranked if _admissible(summary, h)]
        passing = [
            h for h in eligible if _gain(summary, h) >= required and _holds_everywhere(summary, h)
        ]
        return _Standing(
            required=required,
            ranked=ranked,
            eligible=eligible,
            passing=passing,
            chosen=next((h for h in passing if identified(summary, h)), None),
            log_gains={h.effects: math.log(_gain(summary, h)) for h in ranked},
        )


def _gain(summary: Summary, h: Hypothesis) -> float:
    """Held-out improvement of ``h`` over the baseline."""
    return ratio(summary.baseline_cost, h.held_out_cost)


def _score(summary: Summary, h: Hypothesis) -> float:
    """Log held-out improvement less ``PARAMETER_PENALTY`` per own parameter."""
    return math.log(_gain(summary, h)) - PARAMETER_PENALTY * h.parameters


def _admissible(summary: Summary, h: Hypothesis) -> bool:
    """Plausible, not set aside, and a pair only when its second effect earns its place."""
    if not h.plausible or "+".join(h.effects) in summary.stand_ins:
        return False
    if len(h.effects) == 1:
        return True
    base = summary.baseline_cost
    singles = {s.effects: s for s in summary.singles}
    members = [singles[(e,)] for e in h.effects if (e,) in singles]
    better = min((m.held_out_cost for m in members), default=base)
    return (
        ratio(better, h.held_out_cost) >= PAIR_RATIO
        and (better - h.held_out_cost) / base >= PAIR_SHARE
    )


def _holds_everywhere(summary: Summary, h: Hypothesis) -> bool:
    """No held-out window is made worse than ``WINDOW_FLOOR`` times the baseline's."""
    return all(
        ratio(b, w) >= WINDOW_FLOOR for b, w in zip(summary.baseline_window_costs, h.window_costs)
    )


@dataclass(frozen=True)
class _Caps:
    """The margins (log units) a verdict may keep at most, whatever it is.

    ``fixed``: a rule's fixed cap (``STAND_IN_MARGIN``) and its words, where no number of
    the evidence measures the doubt; ``measured``: caps that are margins of the evidence
    (the pair's cut of a single's leftover, the distance below the generic forms' bar).
    """

    fixed: list[tuple[float, str]]
    measured: list[float]

    def apply(self, margins: list[float]) -> tuple[float, str | None]:
        """The least margin and, when a fixed cap is what binds, its words."""
        least = min(margins + self.measured)
        cap = min(self.fixed, default=None)
        if cap is not None and cap[0] < least:
            return cap[0], cap[1]
        return least, None


def _caps(summary: Summary, standing: _Standing) -> _Caps:
    """The caps on the verdict's margin (:class:`_Caps`)."""
    chosen = standing.chosen
    # A hypothesis that would have been named but failed a physics check: the verdict that
    # replaces it is no surer than STAND_IN_MARGIN allows.
    rejected = [
        h
        for h in standing.ranked
        if "+".join(h.effects) in summary.stand_ins
        and _gain(summary, h) >= standing.required
        and h.plausible
    ]
    fixed = [(STAND_IN_MARGIN, SET_ASIDE)] if rejected else []
    measured: list[float] = []
    # A single whose own fitted values show another physics beside it (Candidate.not_alone),
    # or beside a signature in the evidence its law cannot make (Summary.unmade): named
    # alone, no surer than a stand-in's replacement (nothing measures how likely).
    # One that a pair with it betters (Summary.hidden_partner): the pair's log odds, the
    # more the pair cuts its leftover the less sure it is alone.
    # A pair with a member whose own fitted values are not its physics alone (a delay's
    # skew beside a common lag): as a single's, capped in words.
    if chosen is not None and len(chosen.effects) > 1 and summary.doubt(chosen.effects):
        fixed.append((STAND_IN_MARGIN, NOT_ALONE))
    if chosen is not None and len(chosen.effects) == 1:
        name = chosen.effects[0]
        partner = summary.hidden_partner(name)
        if (
            name in summary.not_alone
            or summary.unmade(name) is not None
            or summary.air_beside_words(name) is not None
        ):
            fixed.append((STAND_IN_MARGIN, NOT_ALONE))
        if partner is not None:
            single = next(h for h in summary.singles if h.effects == chosen.effects)
            measured.append(
                -max(
                    summary.pair_odds(single, p)
                    for p in summary.pairs
                    if name in p.effects and p.plausible
                )
            )
    # Hypotheses that would have been named (before the chosen one) but for a generic form
    # doing as well: the verdict is no surer than the nearest stayed below that bar.
    passing = standing.passing
    below_bar = [
        math.log(FORM_RATIO * summary.form_bar(h.effects)) - standing.log_gains[h.effects]
        for h in passing[: passing.index(chosen) if chosen is not None else len(passing)]
    ]
    measured += [min(below_bar)] if below_bar else []
    return _Caps(fixed, measured)


def _named(summary: Summary, standing: _Standing, chosen: Hypothesis, cap: _Caps) -> Verdict:
    """The verdict naming ``chosen``, sure by its smallest margin from the rules."""
    log_gains = standing.log_gains
    own = log_gains[chosen.effects]
    rivals = [
        g
        for effects, g in log_gains.items()
        if not set(effects) & set(chosen.effects) and not holds(effects, chosen.effects)
    ]
    margins = [own - max(rivals, default=0.0), own - math.log(standing.required)]
    if len(chosen.effects) == 1:
        margins += _single_margins(summary, chosen, own, log_gains)
    else:
        margins += _pair_margins(chosen, own, log_gains)
    least, capped = cap.apply(margins)
    return _verdict(summary, chosen.effects, chosen.effects, least, capped)


def _single_margins(
    summary: Summary,
    chosen: Hypothesis,
    own: float,
    log_gains: dict[tuple[str, ...], float],
) -> list[float]:
    """How near a pair with the single ``chosen`` came to being named instead."""
    base = summary.baseline_cost
    margins = [
        max(
            math.log(PAIR_RATIO) - (log_gains[p.effects] - own),
            math.log(PAIR_SHARE * base / max(chosen.held_out_cost - p.held_out_cost, 1e-30)),
        )
        for p in summary.pairs
        if chosen.effects[0] in p.effects and p.plausible
    ]
    if any(chosen.effects[0] in p for p in summary.pairs_ruled_out):
        # a pair that can never be named, fitted or not: the worst its fit could do
        # (an error of zero)
        margins.append(math.log(PAIR_SHARE * base / max(chosen.held_out_cost, 1e-30)))
    return margins


def _pair_margins(
    chosen: Hypothesis, own: float, log_gains: dict[tuple[str, ...], float]
) -> list[float]:
    """How far the pair ``chosen`` clears its better single, and its siblings."""
    alone = max(log_gains.get((e,), 0.0) for e in chosen.effects)
    margins = [own - alone - math.log(PAIR_RATIO)]
    # a pair that keeps one of its effects and swaps the other: which second effect
    siblings = [
        g
        for effects, g in log_gains.items()
        if len(effects) == 2 and len(set(effects) & set(chosen.effects)) == 1
    ]
    margins += [own - max(siblings)] if siblings else []
    return margins


def _not_named(summary: Summary, standing: _Standing, cap: _Caps) -> Verdict:
    """``unexplained`` or none, sure by the nearest miss of the rules.

    Unexplained (rather than none) when the misfit is large, or structured: a generic form
    cuts it ``STRUCTURED_RATIO`` times, or a library effect cuts it the required ratio but no
    better than a generic form. Each test's log distance from its threshold. An
    ``unexplained`` beside such an effect is capped in words (``CAME_CLOSE``).
    """
    log_gains, passing, required = standing.log_gains, standing.passing, standing.required
    # the fall-through's nearest miss of the required ratio (the passing ones missed the form
    # bar instead: their distance from it is the cap)
    best = max((log_gains[h.effects] for h in standing.eligible if h not in passing), default=0.0)
    beyond = (
        math.log(max(summary.baseline_rms, 1e-12) / UNEXPLAINED_RMS),
        math.log(max(summary.form_gain, 1e-12) / STRUCTURED_RATIO),
        *(log_gains[h.effects] - math.log(required) for h in passing),
    )
    unexplained = max(beyond) > 0 or bool(passing)
    margin, capped = cap.apply(
        [math.log(required) - best, max(beyond) if unexplained else -max(beyond)]
    )
    if passing and capped is None:
        # A library effect cleared every rule but the generic forms' bar: the recording
        # holds its signature, and a free form may do better only by also taking a part no
        # library effect makes (a reading's drifting zero beside a seal's stick-slip). That
        # the effect is absent is then no surer than a stand-in's replacement.
        capped = CAME_CLOSE
    effects = ("unexplained",) if unexplained else ()
    if not unexplained and capped is None:
        capped = MAY_HIDE  # above the noise floor (decide_effects): the leftover is unnamed
    return _verdict(summary, effects, None, margin, capped)


def weak_single(summary: Summary) -> Verdict | None:
    """The verdict naming the one effect that explains a misfit under the floor, or None.

    Its margin is the least of its distances from the rule's thresholds (log units).

    A weak effect (a little air, a slightly soft hose) leaves a misfit of a few noise
    variances, as a parameter error does; but a parameter error's residue is cut at most
    about twice by any candidate, while the weak effect's own candidate cuts it
    ``WEAK_SINGLE_RATIO`` times and leaves no more than ``WEAK_SINGLE_LEFT`` times the
    noise. Named only when it is plausible, not set aside by a physics check, holds in
    every held-out window, beats the generic forms (``FORM_RATIO``) and cuts the error at
    least twice as much as any other single; pairs are never named under the floor.
    """
    base = summary.baseline_cost
    ranked = sorted(summary.singles, key=lambda h: h.held_out_cost)
    usable = [h for h in ranked if h.plausible and h.effects[0] not in summary.stand_ins]
    if not usable:
        return None
    best = usable[0]
    others = [ratio(base, h.held_out_cost) for h in ranked if h is not best]
    gain = ratio(base, best.held_out_cost)
    margins = [
        math.log(gain / WEAK_SINGLE_RATIO),
        math.log(WEAK_SINGLE_LEFT * summary.noise_cost / max(best.held_out_cost, 1e-30)),
        math.log(gain / (2.0 * max(others, default=1.0))),
        math.log(gain / (FORM_RATIO * summary.form_bar(best.effects))),
        *(
            math.log(ratio(b, w) / WINDOW_FLOOR)
            for b, w in zip(summary.baseline_window_costs, best.window_costs)
        ),
    ]
    least = min(margins)
    return _verdict(summary, best.effects, best.effects, least) if least >= 0 else None


def identified(summary: Summary, h: Hypothesis) -> bool:
    """The hypothesis explains the misfit better than a generic form of it could.

    It cuts the held-out error ``FORM_RATIO`` times more than the best generic form that is
    not its own physics in a free shape (:meth:`Summary.form_bar`), or it
    leaves no more than ``NOISE_EXCESS`` times the noise's share (then it explains all there
    is to explain, and a form that does as well cannot tell them apart: an offset that a
    form's own offset also absorbs).
    """
    return (
        ratio(summary.baseline_cost, h.held_out_cost) >= FORM_RATIO * summary.form_bar(h.effects)
        or h.held_out_cost <= NOISE_EXCESS * summary.noise_cost
    )


def required_ratio(summary: Summary) -> float:
    """The held-out improvement a hypothesis must reach to be named."""
    return CLEAR_ACCEPT_RATIO if summary.excess_ratio >= CLEAR_EXCESS else ACCEPT_RATIO
