"""Before a candidate is named: does it behave as its physics must?

A candidate that cuts the held-out error may still be a *stand-in*: a flexible term that
absorbs a misfit of another cause. Five checks, each on the fitted hypothesis, none reading
a label. (One more comparison, against the generic forms of the misfit, needs only numbers
of the summary and is in the decision itself, for every hypothesis:
:data:`brake_hil.diagnosis.thresholds.FORM_RATIO`.)

* **Asymmetry** (:func:`asymmetry_check`, a hypothesis with the groove asymmetry only): its
  fitted apply/release asymmetry is resolved (:mod:`.groove`): a groove whose edges the
  recording cannot tell apart is stick-slip or the LTI seal, not a groove.
* **Channels** (:func:`channel_check`): the error it removes is on the channels its physics
  reaches (the catalogue entry's ``channels``), not almost all on others.
* **Segments** (:func:`segment_check`): fitted on each training segment alone, its own
  parameters agree within their uncertainty (and within ``SEGMENT_TOLERANCE``): a physical
  constant is the same at every pressure level; and as tightly as the candidate's physics
  says (``Candidate.segments_disagree``: a delay that shrinks with amplitude is not a
  delay).
* **Rivals** (:func:`rival_check`): physics outside the library that this one may stand in
  for (``Candidate.rivals``: a delayed channel may be read through a resonant tap, a hose's lag
  may be a late ``p_i``, a drift may be the transducers' zeros moving), fitted in its place
  with the calibration refitted, either does not come out as its own physics
  (``Rival.holds``) or leaves ``Rival.told_apart`` times more held-out error than the
  hypothesis.
* **Wider priors** (:func:`prior_check`): with the calibration's priors ``PRIOR_WIDENING``
  times wider (the rig's values freer than its tolerances say), and ``FREED_WIDENING`` times
  wider for the values this recording cannot identify (the Fisher information of the
  calibration: a posterior sigma over ``IDENTIFIABLE_SHARE`` of the prior's), it still cuts
  the error of the baseline so freed by the ratio the decision asks: a candidate that only
  explains what a rig value moved within its tolerance explains is a parameter error, not
  physics. Unless the freed baseline gets there only by moving a rig value
  ``OUT_OF_TOLERANCE_SIGMAS`` of its tolerance from the rig file's, or a value of the
  candidate's own physics ``OWN_VALUE_SIGMAS`` the way that physics moves it (a hose that
  swells more is a softer hose wall), and that value does the explaining (held to its
  tolerance, the others freed, the candidate cuts the error as required): no parameter error
  within tolerance does that, so the candidate is not set aside for it.

:func:`check_hypothesis` runs them, cheapest first, up to the first failure.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from brake_hil.diagnosis.calibration import Calibration
from brake_hil.diagnosis.candidates import candidate, own_columns
from brake_hil.diagnosis.dataset import Dataset
from brake_hil.diagnosis.fitting import Fit, Model, fit
from brake_hil.diagnosis.groove import seal_asymmetry
from brake_hil.diagnosis.summary import ratio
from brake_hil.diagnosis.thresholds import ACCEPT_RATIO
from brake_hil.errors import FitError
from brake_hil.physics.catalogue import entry
from brake_hil.topics import OUTPUT_CHANNELS

__all__ = [
    "FREED_WIDENING",
    "IDENTIFIABLE_SHARE",
    "OWN_VALUE_SIGMAS",
    "PRIOR_WIDENING",
    "SEGMENT_SIGMAS",
    "SEGMENT_TOLERANCE",
    "UNREACHED_SHARE",
    "CheckOutcome",
    "asymmetry_check",
    "channel_check",
    "check_hypothesis",
    "prior_check",
    "rival_check",
    "segment_check",
    "unidentified",
]

UNREACHED_SHARE = 0.8
"""Share of the removed error on channels the effect does not reach that marks a stand-in."""
SEGMENT_SIGMAS = 4.0
"""Segments disagree when their values differ by more than this many combined sigmas ..."""
SEGMENT_TOLERANCE = 0.35
"""... and by more than this share of the parameter's search range (log range for a
logarithmic one: 0.35 of 2e6-2e8 N/m is a factor 5)."""
PRIOR_WIDENING = 2.0
"""The wider priors' sigma over the calibration's ..."""
FREED_WIDENING = 3.0
"""... and of a value the recording does not identify."""
OUT_OF_TOLERANCE_SIGMAS = 5.0
"""Distance (sigmas of its tolerance) of a rig value a freed baseline needs, beyond which it
explains the misfit by no parameter error within tolerance.

The wider-priors check does not set a candidate aside for such a baseline, provided that value
does the explaining (as for ``OWN_VALUE_SIGMAS``). Evidence: docs/diagnosis.md.
"""
OWN_VALUE_SIGMAS = 3.0
"""Distance (sigmas of its tolerance) of a rig value of the candidate's own physics
(``own_rig_values``: a hose's wall stiffness), moved the way that physics moves it, beyond
which a freed baseline describes that physics, not a parameter error within tolerance.

The check does not set the candidate aside for it, provided that value does the explaining:
held to its tolerance with the others freed, the candidate still cuts the error as required
(a value the recording hardly sees drifts far without explaining anything).
Evidence: docs/diagnosis.md.
"""
IDENTIFIABLE_SHARE = 0.5
"""A calibrated value is identified when the data shrink its sigma below this share of the
prior's (posterior from the calibration's Jacobian, prior included)."""
SEGMENT_ITERATIONS = 8
"""Least-squares evaluations of a per-segment fit (it starts from the whole fit)."""


@dataclass(frozen=True)
class CheckOutcome:
    """One check's result: passed, and what it found in words."""

    name: str  # asymmetry, channels, rivals, segments or wider_priors
    passed: bool
    finding: str
    # a rival that explains as well and is a library effect's physics (Rival.stands_for),
    # the hypothesis passing every other check: the two are not told apart
    stands_for: str = ""


def asymmetry_check(hypothesis: Fit, symmetric: Sequence[Fit] = ()) -> CheckOutcome | None:
    """A groove's fitted apply/release asymmetry is resolved (:mod:`.groove`); None: no groove.

    ``symmetric``: the symmetric seals it is held against (baseline, stick-slip single).
    """
    groove = seal_asymmetry(hypothesis, symmetric)
    if groove is None:
        return None
    if groove.asymmetric:
        return CheckOutcome(
            "asymmetry", True, f"apply and release edges differ: {groove.in_words()}"
        )
    return CheckOutcome(
        "asymmetry",
        False,
        f"its apply/release asymmetry is not resolved ({groove.in_words()}): the recording "
        "does not tell the groove from a symmetric seal",
    )


def channel_check(baseline: Fit, hypothesis: Fit) -> CheckOutcome:
    """The error it removes is not almost all on channels its physics does not reach.

    Every effect on the piston or the caliper moves fluid and so reaches ``p_b`` too through
    the line; the check only refuses an improvement ``UNREACHED_SHARE`` or more of which is
    on channels the catalogue entries do not list, while the channels it reaches see their
    error cut less than ``ACCEPT_RATIO`` times (the bar of a named effect): a stand-in mends
    what it cannot reach, a real effect mends its own channels too, even where the baseline
    missed another channel most (a seal's recalibrated line on a sweep).
    """
    reached = {c for name in hypothesis.effects for c in entry(name).channels}
    drops = {
        key: max(baseline.held_out_rms[key] ** 2 - hypothesis.held_out_rms[key] ** 2, 0.0)
        for key in OUTPUT_CHANNELS
    }
    total = sum(drops.values())
    elsewhere = [key for key in OUTPUT_CHANNELS if key not in reached]
    share = sum(drops[key] for key in elsewhere) / total if total > 0 else 0.0
    if share < UNREACHED_SHARE:
        return CheckOutcome(
            "channels",
            True,
            f"{100 * (1 - share):.0f} % of the error removed is on "
            f"{', '.join(sorted(reached))}, which its physics reaches",
        )
    own_cut, other_cut = (
        ratio(
            sum(baseline.held_out_rms[k] ** 2 for k in keys),
            sum(hypothesis.held_out_rms[k] ** 2 for k in keys),
        )
        for keys in ([k for k in OUTPUT_CHANNELS if k in reached], elsewhere)
    )
    if own_cut >= ACCEPT_RATIO:
        return CheckOutcome(
            "channels",
            True,
            f"{100 * share:.0f} % of the error removed is on {', '.join(elsewhere)}, but that "
            f"of {', '.join(sorted(reached))}, which its physics reaches, falls "
            f"{own_cut:.1f} times ({other_cut:.1f} on the others)",
        )
    return CheckOutcome(
        "channels",
        False,
        f"{100 * share:.0f} % of the error it removes is on {', '.join(elsewhere)}, which "
        f"{' and '.join(hypothesis.effects)} does not reach ({', '.join(sorted(reached))})",
    )


def segment_check(model: Model, hypothesis: Fit) -> CheckOutcome:
    """Fitted on each training segment alone, the effects' own parameters agree."""
    own = model.effect_size
    if own == 0 or len(model.dataset.train) < 2:
        return CheckOutcome("segments", True, "one segment: nothing to compare")
    specs = model.parameters()[:own]
    logarithmic = np.array([log for *_, log in specs], dtype=bool)
    per_segment: list[tuple[np.ndarray, np.ndarray]] = []
    raw: list[np.ndarray] = []  # each segment's own values, in the parameters' units
    for window in model.dataset.train:
        alone = Model(model.calibration, model.candidates, replace(model.dataset, train=(window,)))
        try:
            fitted = fit(alone, start=hypothesis.theta, max_iterations=SEGMENT_ITERATIONS)
        except FitError:
            continue
        values = fitted.theta[:own]
        raw.append(np.asarray(values, dtype=float))
        sigma = (
            np.full(own, np.inf)
            if fitted.uncertainty is None
            else np.asarray(fitted.uncertainty[:own], dtype=float)
        )
        search = np.where(logarithmic, np.log(np.maximum(values, 1e-300)), values)
        search_sigma = np.where(logarithmic, sigma / np.maximum(np.abs(values), 1e-300), sigma)
        per_segment.append((search, np.nan_to_num(search_sigma, nan=np.inf)))
    for j, (name, unit, low, high, log) in enumerate(specs):
        width = (np.log(high) - np.log(low)) if log else (high - low)
        for a in range(len(per_segment)):
            for b in range(a + 1, len(per_segment)):
                (va, sa), (vb, sb) = per_segment[a], per_segment[b]
                gap = abs(va[j] - vb[j])
                with np.errstate(over="ignore"):  # an unidentified value: infinite sigma
                    combined = float(np.hypot(sa[j], sb[j]))
                if gap > SEGMENT_SIGMAS * combined and gap > SEGMENT_TOLERANCE * width:
                    shown = [f"{np.exp(v[j]) if log else v[j]:.3g}" for v, _ in per_segment]
                    return CheckOutcome(
                        "segments",
                        False,
                        f"{name} differs between the segments ({', '.join(shown)} {unit}, "
                        f"low to high pressure): a constant of this physics would not",
                    )
    if len(raw) >= 2:
        for member, columns in own_columns(model.candidates, np.vstack(raw)):
            finding = member.segments_disagree(columns)
            if finding is not None:
                return CheckOutcome("segments", False, finding)
    return CheckOutcome("segments", True, f"its parameters agree over {len(per_segment)} segments")


def rival_check(model: Model, hypothesis: Fit) -> CheckOutcome:
    """No rival physics, fitted in a member's place, is its own and explains about as well."""
    members = list(model.candidates)
    told: list[str] = []
    for index, (member, own) in enumerate(own_columns(members, hypothesis.theta)):
        for rival in member.rivals(own):
            replaced = [rival if k == index else m for k, m in enumerate(members)]
            try:
                fitted = fit(Model(model.calibration, replaced, model.dataset))
            except FitError:
                continue
            values = list(own_columns(replaced, fitted.theta))[index][1]
            apart = fitted.held_out_cost / max(hypothesis.held_out_cost, 1e-300)
            holds = rival.holds(values)
            if holds and apart < rival.told_apart:
                lower = "" if rival.told_apart == 1.0 else f"{rival.told_apart:g} times "
                return CheckOutcome(
                    "rivals",
                    False,
                    f"{rival.in_words(values)} explains it as well: its held-out error is "
                    f"{apart:.2f} times {member.name}'s, which would have to be {lower}lower "
                    f"to tell them apart; {rival.why}",
                    rival.stands_for,
                )
            unlike = "" if holds else f", {rival.unlike}"
            told.append(
                f"{rival.in_words(values)}{unlike}: held-out error {apart:.2f} times "
                f"{member.name}'s"
            )
    if not told:
        return CheckOutcome("rivals", True, "no rival its physics could stand in for")
    return CheckOutcome("rivals", True, f"told from its rivals: {'; '.join(told)}")


def prior_check(
    calibration: Calibration, dataset: Dataset, hypothesis: Fit, required: float
) -> CheckOutcome:
    """With priors wider (unidentified values freer still) it still cuts the freed error."""
    freed = unidentified(calibration)
    wider = replace(
        calibration,
        sigmas={
            k: (FREED_WIDENING if k in freed else PRIOR_WIDENING) * v
            for k, v in calibration.sigmas.items()
        },
    )
    named = f" ({', '.join(freed)} {FREED_WIDENING:g} times: not identified)" if freed else ""
    try:
        baseline = fit(Model(wider, [], dataset))
        again = fit(
            Model(wider, [candidate(e) for e in hypothesis.effects], dataset),
            start=hypothesis.theta,
        )
    except FitError as error:
        return CheckOutcome("wider_priors", True, f"not checked: {error}")
    gain = baseline.held_out_cost / max(again.held_out_cost, 1e-18)
    if gain >= required:
        return CheckOutcome(
            "wider_priors",
            True,
            f"with priors {PRIOR_WIDENING:g} times wider{named} it still cuts the error "
            f"{gain:.1f} times",
        )
    moved = far_moved_value(calibration, baseline, hypothesis.effects)
    aside = ""
    if moved is not None:
        name, sigmas, why = moved
        held = replace(wider, sigmas={**wider.sigmas, name: calibration.sigmas[name]})
        try:
            held_gain = fit(Model(held, [], dataset)).held_out_cost / max(
                again.held_out_cost, 1e-18
            )
        except FitError:
            held_gain = 0.0
        if held_gain >= required:
            return CheckOutcome(
                "wider_priors",
                True,
                f"with priors {PRIOR_WIDENING:g} times wider{named} the baseline comes within "
                f"{gain:.2f} times of it only by moving {name} {sigmas:.1f} sigmas of its "
                f"tolerance from the rig file's value (held to its tolerance, the others "
                f"freed, it cuts the error {held_gain:.1f} times): {why}",
            )
        aside = (
            f"; its {name} moved {sigmas:.1f} sigmas, but held to its tolerance the baseline "
            f"still comes within {held_gain:.2f} times"
        )
    return CheckOutcome(
        "wider_priors",
        False,
        f"with the rig's values {PRIOR_WIDENING:g} times freer than their tolerances{named} "
        f"the baseline alone comes within {gain:.2f} times of it (under the {required:g} "
        f"required{aside}): a parameter error, not this physics",
    )


def rig_value_moves(calibration: Calibration, fitted: Fit) -> dict[str, float]:
    """How far ``fitted`` moved each rig value from the rig file's, in its tolerance's sigmas.

    Signed: the log of the value over the rig file's, over the prior's sigma. ``fitted``'s
    ``calibration.NAME`` parameters multiply the calibrated values.
    """
    moves = {}
    for key, factor in fitted.parameters().items():
        name = key.removeprefix("calibration.")
        if name == key or name not in calibration.sigmas or factor <= 0:
            continue
        total = factor * calibration.multipliers[name]
        moves[name] = float(np.log(total)) / calibration.sigmas[name]
    return moves


def farthest_rig_value(calibration: Calibration, fitted: Fit) -> tuple[str, float]:
    """The rig value ``fitted`` moved farthest from the rig file's, in its tolerance's sigmas."""
    moves = rig_value_moves(calibration, fitted)
    if not moves:
        return "", 0.0
    farthest = max(moves, key=lambda name: abs(moves[name]))
    return farthest, abs(moves[farthest])


def far_moved_value(
    calibration: Calibration, fitted: Fit, effects: tuple[str, ...]
) -> tuple[str, float, str] | None:
    """A rig value ``fitted`` moved farther than a parameter error within tolerance would.

    Name, sigmas and why that is no parameter error, or None: first a value of ``effects``'
    own physics moved ``OWN_VALUE_SIGMAS`` of its tolerance's sigmas from the rig file's value
    the way that physics moves it (their ``own_rig_values``), else the farthest value when it
    moved ``OUT_OF_TOLERANCE_SIGMAS``.
    """
    moves = rig_value_moves(calibration, fitted)
    for effect in effects:
        for name, sign in candidate(effect).own_rig_values:
            if sign * moves.get(name, 0.0) >= OWN_VALUE_SIGMAS:
                return (
                    name,
                    sign * moves[name],
                    f"the way {effect} moves it, this physics in the calibration's terms",
                )
    name, sigmas = farthest_rig_value(calibration, fitted)
    if sigmas >= OUT_OF_TOLERANCE_SIGMAS:
        return name, sigmas, "no parameter error within tolerance"
    return None


def unidentified(calibration: Calibration) -> tuple[str, ...]:
    """Calibrated values the recording does not identify (posterior near the prior)."""
    return tuple(
        name
        for name, prior in calibration.sigmas.items()
        if calibration.uncertainty.get(name, prior) > IDENTIFIABLE_SHARE * prior
    )


def check_hypothesis(
    calibration: Calibration,
    dataset: Dataset,
    baseline: Fit,
    hypothesis: Fit,
    required: float,
    symmetric: Sequence[Fit] = (),
) -> list[CheckOutcome]:
    """The checks of ``hypothesis``, cheapest first, stopping at the first failure.

    A rival that is a library effect's physics (``CheckOutcome.stands_for``) does not stop
    them: the tie stands only when every other check passes, else it is a plain failure.
    ``symmetric``: the symmetric seals a groove is held against (:func:`asymmetry_check`).
    """
    asymmetry = asymmetry_check(hypothesis, symmetric)
    if asymmetry is not None and not asymmetry.passed:
        return [asymmetry]
    outcomes = [*([asymmetry] if asymmetry else []), channel_check(baseline, hypothesis)]
    model = Model(calibration, [candidate(e) for e in hypothesis.effects], dataset)
    if outcomes[-1].passed:
        outcomes.append(rival_check(model, hypothesis))
    tie = outcomes[-1] if outcomes[-1].stands_for else None
    if outcomes[-1].passed or tie is not None:
        outcomes.append(segment_check(model, hypothesis))
    if outcomes[-1].passed:
        outcomes.append(prior_check(calibration, dataset, hypothesis, required))
    if tie is not None and not outcomes[-1].passed:
        outcomes[outcomes.index(tie)] = replace(tie, stands_for="")
    return outcomes
