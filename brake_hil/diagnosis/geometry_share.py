"""The caliper's share of the pressure force that the rig's geometry allows.

An error of the bore's area ratio within its tolerance changes the share of ``A_eb p_b`` the
caliper sees exactly as a constant eccentric share does, and no calibrated multiplier moves
that share (``tolerance_prior.share_band``). So an ``eccentric_load`` whose fitted share is
one the geometry makes (:func:`~.candidates.eccentric_load.geometry_share`) is the
hypothesis beside it with the geometry's share calibrated: its held-out numbers are folded
into that hypothesis (the single eccentric load into none, a pair into its other effect),
and it is itself not a nameable hypothesis (``plausible`` false). The fold is done once, when
the decision's inputs are made, and the stand-ins are stored (``Summary.geometry``), so the
decision stays a pure function of ``decision_inputs``.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

import numpy as np

from brake_hil.diagnosis.candidates import candidate, own_columns
from brake_hil.diagnosis.candidates.eccentric_load import geometry_share
from brake_hil.diagnosis.dataset import Dataset
from brake_hil.diagnosis.fitting import Fit
from brake_hil.diagnosis.summary import Hypothesis, Summary

__all__ = ["ECCENTRIC", "checked_fit", "fold_geometry", "geometry_stand_ins", "recorded_pressures"]

ECCENTRIC = "eccentric_load"
PRESSURE_PERCENTILES = (1.0, 99.0)
"""The recorded bore pressures' range: these percentiles of the training windows' ``p_b``."""


def recorded_pressures(dataset: Dataset) -> tuple[float, float]:
    """The lowest and highest bore pressure (Pa) of the training windows."""
    inside = dataset.mask(dataset.train) > 0
    low, high = np.percentile(dataset.measured["p_b"][inside], PRESSURE_PERCENTILES)
    return float(low), float(high)


def geometry_stand_ins(
    fits: Iterable[Fit], band: float, pressures: tuple[float, float]
) -> dict[str, str]:
    """``"a+b"``: why its eccentric load is the rig's geometry, for every such fit."""
    found: dict[str, str] = {}
    for fit in fits:
        if ECCENTRIC not in fit.effects:
            continue
        members = [candidate(e) for e in fit.effects]
        for member, own in own_columns(members, fit.theta):
            why = geometry_share(own, band, pressures) if member.name == ECCENTRIC else None
            if why is not None:
                found["+".join(fit.effects)] = why
    return found


def fold_geometry(summary: Summary, stand_ins: dict[str, str]) -> Summary:
    """``summary`` with each geometry stand-in folded into the hypothesis beside it.

    A stand-in that leaves less held-out error than its host (none for the single, the other
    effect for a pair) gives the host its costs; the stand-in stays listed but not plausible.
    The generic forms' gains are rescaled to the folded baseline (a form's own cost stays).
    """
    if not stand_ins:
        return summary
    singles = {h.effects: h for h in summary.singles}
    base = Hypothesis(
        (),
        0,
        summary.baseline_cost,
        summary.baseline_window_costs,
        True,
        True,
        dict(summary.baseline_channel_nrmse),
    )
    for h in (*summary.singles, *summary.pairs):
        if "+".join(h.effects) not in stand_ins:
            continue
        host_effects = tuple(e for e in h.effects if e != ECCENTRIC)
        host = singles.get(host_effects) if host_effects else base
        if host is None or h.held_out_cost >= host.held_out_cost:
            continue
        folded = replace(
            host,
            held_out_cost=h.held_out_cost,
            window_costs=h.window_costs,
            channel_nrmse=dict(h.channel_nrmse),
        )
        if host_effects:
            singles[host_effects] = folded
        else:
            base = folded

    def aside(h: Hypothesis) -> Hypothesis:
        return replace(h, plausible=False) if "+".join(h.effects) in stand_ins else h

    scale = base.held_out_cost / max(summary.baseline_cost, 1e-300)
    return replace(
        summary,
        baseline_cost=base.held_out_cost,
        baseline_window_costs=base.window_costs,
        baseline_nrmse=max(base.channel_nrmse.values(), default=summary.baseline_nrmse),
        baseline_channel_nrmse=base.channel_nrmse,
        singles=tuple(aside(singles[h.effects]) for h in summary.singles),
        pairs=tuple(aside(h) for h in summary.pairs),
        form_gain=summary.form_gain * scale,
        form_gains={k: v * scale for k, v in summary.form_gains.items()},
        geometry=dict(stand_ins),
    )


def checked_fit(fits: Iterable[Fit], chosen: tuple[str, ...], summary: Summary) -> Fit | None:
    """The fit whose numbers the decision gave ``chosen``: its own, or a folded stand-in's.

    When ``chosen``'s held-out numbers are those of ``chosen`` beside a geometry stand-in
    (:func:`fold_geometry`), its physics is checked on that fit, with the geometry's share:
    the checks judge the hypothesis the decision named, not one without the geometry.
    """
    candidates = list(fits)
    own = next((f for f in candidates if f.effects == chosen), None)
    for key in summary.geometry:
        effects = tuple(key.split("+"))
        if tuple(e for e in effects if e != ECCENTRIC) != chosen or not chosen:
            continue
        folded = next((f for f in candidates if f.effects == effects), None)
        if folded is not None and (own is None or folded.held_out_cost < own.held_out_cost):
            return folded
    return own
