"""The numbers a verdict is decided from (:class:`Summary`), taken from the fits.

A :class:`Summary` holds no fits, only their held-out costs and a few flags, and is JSON-able
(``diagnosis.json``: ``decision_inputs``), so a decision (:func:`.verdict.decide`) is a pure
function of stored inputs and can be replayed.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from brake_hil.diagnosis.calibration import Calibration
from brake_hil.diagnosis.candidates import CANDIDATES, candidate, own_columns
from brake_hil.diagnosis.evidence import Evidence
from brake_hil.diagnosis.fitting import Fit
from brake_hil.diagnosis.likelihood import log_evidence, log_prior
from brake_hil.diagnosis.rig_findings import AIR_BESIDE_CUT, AIR_MORE_RATIO, outside
from brake_hil.diagnosis.thresholds import NOISE_EXCESS, PAIR_SHARE, SIGNIFICANT_Z
from brake_hil.words import energy_share, noise_times

__all__ = [
    "Hypothesis",
    "Summary",
    "not_alone",
    "own_values_beside",
    "own_values_outside",
    "plausible",
    "ratio",
    "summarise",
    "unmade_signature",
]


@dataclass(frozen=True)
class Hypothesis:
    """What the decision needs of one fitted candidate set (numbers only)."""

    effects: tuple[str, ...]
    parameters: int  # the effects' own fitted parameters
    held_out_cost: float  # mean over channels of the squared held-out RMS (``baseline_rms``)
    window_costs: tuple[float, ...]  # the same per held-out window
    plausible: bool  # fitted parameters describe the physics (Candidate.plausible)
    consistent: bool  # the evidence shows its signature (Candidate.consistent)
    channel_rms: dict[str, float] = field(default_factory=dict)  # held-out, per channel


@dataclass(frozen=True)
class Summary:
    """The numbers a verdict is decided from; JSON-able, so a decision can be replayed."""

    baseline_cost: float
    baseline_window_costs: tuple[float, ...]
    baseline_rms: float  # worst channel's held-out RMS over its peak-to-peak (all segments)
    noise_cost: float  # the measurement noise's share of any held-out cost
    singles: tuple[Hypothesis, ...]
    pairs: tuple[Hypothesis, ...]
    baseline_channel_rms: dict[str, float] = field(default_factory=dict)  # held-out
    pairs_ruled_out: tuple[tuple[str, ...], ...] = ()  # can never be named (unnameable_pairs)
    stand_ins: dict[str, str] = field(default_factory=dict)  # "a+b": the physics check failed
    # "a+b" set aside only by a rival that is this library effect's physics (ties.py)
    not_told_from: dict[str, str] = field(default_factory=dict)
    not_alone: dict[str, str] = field(default_factory=dict)  # "a" or "a+b": Candidate.not_alone
    # single: the even harmonics of p_b its fit leaves, share (%), z, power (unmade_signature)
    even_left: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    form_gain: float = 1.0  # the best generic form's held-out improvement (residual_forms)
    form_gains: dict[str, float] = field(default_factory=dict)  # "form channel": improvement
    # single -> (air over the rig file's, cut of the single's error) of its pair with air
    air_beside: dict[str, tuple[float, float]] = field(default_factory=dict)
    # every window steady pulsing at the rig's frequency, as the confidence was fitted on
    steady: bool = True
    # effects whose own rig value the calibrated baseline moved outside its tolerance, the
    # way that physics moves it (own_values_outside)
    own_values_outside: tuple[str, ...] = ()
    # single -> the other effects whose own rig values its fit carries so (own_values_beside)
    own_values_beside: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def form_bar(self, effects: tuple[str, ...]) -> float:
        """The best generic form's improvement that counts against ``effects``.

        Forms that are one of the effects' own physics in a free shape
        (``Candidate.kin_forms``) do not count; without per-form gains, the best form's.
        """
        if not self.form_gains:
            return self.form_gain
        kin = {f"{form} {channel}" for e in effects for form, channel in candidate(e).kin_forms}
        return max((g for key, g in self.form_gains.items() if key not in kin), default=1.0)

    def doubt(self, effects: tuple[str, ...]) -> str | None:
        """Why ``effects`` may not be alone (a pair: a member's values, :attr:`not_alone`).

        Its own fitted values show another physics beside it (:attr:`not_alone`), a pair
        with it has the larger posterior while it leaves more than ``NOISE_EXCESS`` times the
        noise's share (:meth:`hidden_partner`), or the evidence shows a signature its law
        cannot make (:meth:`unmade`). A second effect the pair identifies is said before the
        signature's doubt, which names none.
        """
        if "+".join(effects) in self.not_alone:
            return self.not_alone["+".join(effects)]
        if len(effects) != 1:
            return None
        partner = self.hidden_partner(effects[0])
        air = self.air_beside_words(effects[0])
        if air is not None and (partner is None or partner[0] is None):
            return air
        unmade = self.unmade(effects[0])
        if unmade is not None and (partner is None or partner[0] is None):
            return unmade
        if partner is None:
            return None
        other, cut = partner
        if other is None:
            return (
                f"a pair with it leaves {cut:.2f} times less of the error than {effects[0]} "
                "alone: a second effect is likely; not identified (no effect that cuts it so "
                "has its signature in the evidence and physical fitted values)"
            )
        return (
            f"with {other} beside it the fit leaves {cut:.2f} times less of the error than "
            f"{effects[0]} alone: a second effect too small a share of the baseline's error "
            f"to be named ({100 * PAIR_SHARE:g} % is asked), or a part of {effects[0]}'s "
            "physics its model does not follow"
        )

    def air_beside_words(self, name: str) -> str | None:
        """More air than the rig file says beside single ``name``, in words (or None).

        Its pair with entrained air fits more than ``AIR_MORE_RATIO`` times the rig file's
        air and cuts what it leaves ``AIR_BESIDE_CUT`` times or more (:func:`.air_beside`).
        """
        found = self.air_beside.get(name)
        if found is None or found[0] <= AIR_MORE_RATIO or found[1] < AIR_BESIDE_CUT:
            return None
        return (
            f"with entrained_air beside it the fit finds {found[0]:.1f} times the rig file's "
            f"air and leaves {found[1]:.2f} times less of the error than {name} alone: more "
            "air than the rig file says is likely there too (bleed the brake and test again)"
        )

    def air_shows(self, effects: tuple[str, ...]) -> bool:
        """Single ``effects``'s pair with entrained air shows more air (``air_beside_words``)."""
        return len(effects) == 1 and self.air_beside_words(effects[0]) is not None

    def unmade(self, name: str) -> str | None:
        """Why single ``name`` is likely not alone by even harmonics it leaves (or None)."""
        left = self.even_left.get(name)
        return None if left is None else unmade_signature(name, left, self.noise_cost)

    def leaves_beyond_noise(self, name: str) -> bool:
        """Single ``name`` leaves more than ``NOISE_EXCESS`` times the noise's share."""
        single = next((h for h in self.singles if h.effects == (name,)), None)
        return single is not None and single.held_out_cost > NOISE_EXCESS * self.floor_cost

    def pair_odds(self, single: Hypothesis, pair: Hypothesis) -> float:
        """Log posterior odds of ``pair`` over ``single`` (:func:`.posterior.log_evidence`).

        Positive when the pair's held-out likelihood gain outweighs its extra parameters'
        charge and its smaller prior: the held-out evidence says the second effect is there.
        """
        floor = self.floor_cost
        count = len(self.singles)
        return (
            log_evidence(pair.held_out_cost, pair.parameters, floor)
            + log_prior(2, count)
            - log_evidence(single.held_out_cost, single.parameters, floor)
            - log_prior(1, count)
        )

    def hidden_partner(self, name: str) -> tuple[str | None, float] | None:
        """The second effect beside single ``name`` and the cut of a pair with it; or None.

        The cut is how many times the best pair with ``name`` (plausible, not set aside)
        cuts the error ``name`` leaves; None unless that pair's posterior beats the single's
        (:meth:`pair_odds` positive: a held-out misfit beyond noise that the pair cuts more
        than its extra parameters can). The second effect is named only when its physics
        checks pass: its own signature is in the evidence (the single's ``consistent``), its
        values fitted alone are one instance of its physics (not in :attr:`not_alone`), the
        pair's fitted values describe its physics (``plausible``), and that pair too wins
        over the single; else it is None (a second effect is likely, not identified). Only
        for a single that leaves more than ``NOISE_EXCESS`` times the noise's share: under
        that, no second effect is there to find.
        """
        single = next((h for h in self.singles if h.effects == (name,)), None)
        if single is None or not self.leaves_beyond_noise(name):
            return None
        pairs = [
            p
            for p in self.pairs
            if name in p.effects
            and p.plausible
            and "+".join(p.effects) not in self.stand_ins
            and self.pair_odds(single, p) > 0.0
        ]
        best = min(pairs, key=lambda p: p.held_out_cost, default=None)
        if best is None:
            return None
        cut = ratio(single.held_out_cost, best.held_out_cost)
        # its own fit alone must describe one instance of its physics too (not_alone: a
        # delay whose skew and common lag are a lag of the line, as air's, is not a delay)
        seen = {h.effects[0] for h in self.singles if h.consistent} - set(self.not_alone)
        shown = [p for p in pairs if all(e in seen for e in p.effects if e != name)]
        named = min(shown, key=lambda p: p.held_out_cost, default=None)
        other = None if named is None else next(e for e in named.effects if e != name)
        return other, cut

    @property
    def floor_cost(self) -> float:
        """The noise's share of the held-out cost, at most what any fitted model left.

        The cycle-to-cycle estimate (:meth:`Dataset.noise_cost`) counts what changes in one
        cycle as noise, so a slow change (a leak, a shifting zero) inflates it; but no model
        fitted on the training windows can predict the held-out noise, so every held-out cost
        reached (a candidate's, a generic form's) bounds it from above.
        """
        reached = [h.held_out_cost for h in (*self.singles, *self.pairs)]
        reached.append(self.baseline_cost / max(self.form_gain, 1.0))
        return min(self.noise_cost, *reached)

    @property
    def excess_ratio(self) -> float:
        """Baseline held-out cost over the noise's share of it (:attr:`floor_cost`)."""
        return self.baseline_cost / max(self.floor_cost, 1e-18)

    def as_dict(self) -> dict[str, object]:
        """Plain JSON."""
        return asdict(self)

    @staticmethod
    def from_dict(document: dict[str, Any]) -> Summary:
        """Inverse of :meth:`as_dict`."""

        def hypotheses(items: list[dict[str, Any]]) -> tuple[Hypothesis, ...]:
            return tuple(
                Hypothesis(
                    **{
                        **{_RENAMED.get(k, k): v for k, v in item.items()},
                        "effects": tuple(item["effects"]),
                        "window_costs": tuple(item["window_costs"]),
                    }
                )
                for item in items
            )

        document = {_RENAMED.get(k, k): v for k, v in document.items()}

        return Summary(
            baseline_cost=float(document["baseline_cost"]),
            baseline_window_costs=tuple(document["baseline_window_costs"]),
            baseline_rms=float(document["baseline_rms"]),
            noise_cost=float(document["noise_cost"]),
            singles=hypotheses(document["singles"]),
            pairs=hypotheses(document["pairs"]),
            baseline_channel_rms=dict(document.get("baseline_channel_rms", {})),
            pairs_ruled_out=tuple(tuple(p) for p in document.get("pairs_ruled_out", ())),
            stand_ins=dict(document.get("stand_ins", {})),
            not_told_from=dict(document.get("not_told_from", {})),
            not_alone=dict(document.get("not_alone", {})),
            even_left={
                str(k): (float(v[0]), float(v[1]), float(v[2]))
                for k, v in document.get("even_left", {}).items()
            },
            form_gain=float(document.get("form_gain", 1.0)),
            form_gains={str(k): float(v) for k, v in document.get("form_gains", {}).items()},
            air_beside={
                str(k): (float(v[0]), float(v[1]))
                for k, v in document.get("air_beside", {}).items()
            },
            steady=bool(document.get("steady", True)),
            own_values_outside=tuple(document.get("own_values_outside", ())),
            own_values_beside={
                str(k): tuple(v) for k, v in document.get("own_values_beside", {}).items()
            },
        )


_RENAMED = {
    "baseline_nrmse": "baseline_rms",
    "baseline_channel_nrmse": "baseline_channel_rms",
    "channel_nrmse": "channel_rms",
}
"""Keys of summaries stored before the held-out error's per-channel RMS got its own name (it
is over the peak-to-peak of all the steady segments together, not the paper's NRMSE): read
under the new names, so a stored decision replays."""


def summarise(
    baseline: Fit,
    singles: list[Fit],
    pairs: list[Fit],
    noise_cost: float,
    evidence: Evidence,
    pairs_ruled_out: frozenset[tuple[str, ...]] = frozenset(),
    form_gains: dict[str, float] | None = None,
    even_left: dict[str, tuple[float, float, float]] | None = None,
    air_beside: dict[str, tuple[float, float]] | None = None,
    steady: bool = True,
    own_values: tuple[str, ...] = (),
    own_beside: dict[str, tuple[str, ...]] | None = None,
) -> Summary:
    """The decision's inputs from the fits.

    Also the pairs left unfitted as unnameable, the best generic form's held-out
    improvement (:mod:`.residual_forms`), the singles a signature they leave says are
    not alone (``even_left``: the even harmonics of ``p_b`` each single's fit leaves,
    :func:`unmade_signature`), and whether the recording is steady pulsing only
    (:attr:`.dataset.Dataset.steady`), and the effects whose own rig value the calibrated
    baseline carries outside its tolerance (:func:`own_values_outside`), and beside each
    single, those its fit carries so (:func:`own_values_beside`).
    """

    def hypothesis(h: Fit) -> Hypothesis:
        return Hypothesis(
            effects=h.effects,
            parameters=len(h.theta) - len(baseline.theta),
            held_out_cost=h.held_out_cost,
            window_costs=h.window_costs,
            plausible=plausible(h),
            consistent=all(candidate(e).consistent(evidence.values) for e in h.effects),
            channel_rms=dict(h.held_out_rms),
        )

    return Summary(
        baseline_cost=baseline.held_out_cost,
        baseline_window_costs=baseline.window_costs,
        baseline_rms=max(baseline.held_out_rms.values()),
        noise_cost=noise_cost,
        singles=tuple(hypothesis(h) for h in singles),
        pairs=tuple(hypothesis(h) for h in pairs),
        baseline_channel_rms=dict(baseline.held_out_rms),
        pairs_ruled_out=tuple(sorted(pairs_ruled_out)),
        not_alone={
            "+".join(h.effects): why
            for h in (*singles, *pairs)
            if (why := not_alone(h)) is not None
        },
        even_left=dict(even_left or {}),
        form_gain=max((form_gains or {}).values(), default=1.0),
        form_gains=dict(form_gains or {}),
        air_beside=dict(air_beside or {}),
        steady=steady,
        own_values_outside=own_values,
        own_values_beside=dict(own_beside or {}),
    )


def own_values_outside(
    calibration: Calibration, parameters: Mapping[str, float] | None = None, named: str = ""
) -> tuple[str, ...]:
    """Effects whose own rig value a model moved outside its tolerance their way.

    ``Candidate.own_rig_values`` (a hose's wall stiffness, lower for a hose that swells
    more) whose multiplier is outside the band the tolerances allow
    (:func:`.rig_findings.outside`, as ``verdict.rig_values`` flags it) on that physics' side
    of 1: the model fits the recording by carrying that physics as a rig value. The model is
    the calibrated LTI one, or a hypothesis's fit (its ``parameters``: ``calibration.NAME``
    multipliers), whose own effect ``named`` is left out.
    """
    found = []
    for effect in CANDIDATES:
        for name, sign in effect.own_rig_values:
            m = calibration.multipliers.get(name, 1.0)
            if parameters is not None:
                m = parameters.get(f"calibration.{name}", m)
            sigma = calibration.sigmas.get(name)
            if sigma is None or m <= 0 or sign * np.log(m) <= 0 or effect.name == named:
                continue
            if outside(m, sigma, calibration.uncertainty.get(name, sigma)):
                found.append(effect.name)
    return tuple(dict.fromkeys(found))


def own_values_beside(
    calibration: Calibration, singles: Sequence[Fit]
) -> dict[str, tuple[str, ...]]:
    """Each single whose fit carries other effects' own rig values outside their tolerance.

    Those effects (:func:`own_values_outside` of the single's fit): the single's model fits the
    recording by carrying a second physics as a rig value (bore friction named, the hose wall
    at a third of the rig file's modulus).
    """
    found = {}
    for single in singles:
        name = single.effects[0]
        beside = own_values_outside(calibration, single.parameters(), name)
        if beside:
            found[name] = beside
    return found


def ratio(reference: float, cost: float) -> float:
    """How many times ``cost`` is below ``reference`` (held-out improvement)."""
    return reference / max(cost, 1e-18)


def plausible(fit: Fit) -> bool:
    """Every effect's fitted parameters describe that physics (see Candidate.plausible)."""
    members = [candidate(name) for name in fit.effects]
    return all(member.plausible(own) for member, own in own_columns(members, fit.theta))


def unmade_signature(name: str, left: tuple[float, float, float], noise_cost: float) -> str | None:
    """Why single ``name`` is likely not alone by a signature its law cannot make; else None.

    ``left``: the even harmonics of ``p_b`` its own fitted model leaves, their share (%), its
    z and their power on the held-out costs' scale (:func:`.evidence.even_harmonics_left`).
    More than ``SIGNIFICANT_Z`` standard errors of their scatter over the cycles, and more
    than ``NOISE_EXCESS`` times the noise's share of the error (the bar below which a misfit
    is the residue of a parameter error), beside a law the same on apply and release
    (``Candidate.even_harmonics`` false: it cannot make them), they are another physics (air
    whose compliance falls with the pressure, an asymmetric groove, a load share), whether
    or not a pair identifies it.
    """
    share, z, power = left
    if candidate(name).even_harmonics or not z > SIGNIFICANT_Z:
        return None
    if not power > NOISE_EXCESS * noise_cost:
        return None
    makers = ", ".join(sorted(c.name for c in CANDIDATES if c.even_harmonics))
    return (
        f"a second effect is likely; not identified: {name} fitted leaves even harmonics in the "
        f"bore pressure ({energy_share(share)} of its energy, {z:.0f} standard errors of their "
        f"scatter over the cycles, {noise_times(power / max(noise_cost, 1e-30))}) that its "
        f"law, the same on apply and release, cannot make: the signature of one of {makers} "
        f"(air's compliance falls with the pressure)"
    )


def not_alone(fit: Fit) -> str | None:
    """Why a hypothesis's fitted values say it is likely not all (Candidate.not_alone).

    A single's own values; in a pair, either member's (a delay whose skew and common lag are
    two timing errors beside an orifice is the orifice's lag read as a delay, or a third
    effect), said with the member's name.
    """
    members = [candidate(name) for name in fit.effects]
    for member, own in own_columns(members, fit.theta):
        why = member.not_alone(own)
        if why is not None:
            return why if len(members) == 1 else f"{member.name}: {why}"
    return None
