"""eccentric_load: the caliper takes a load-dependent share of the pressure force."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
)
from brake_hil.diagnosis.candidates.registry import register_candidate_class
from brake_hil.diagnosis.engine import CALIPER_FORCE, State, Step, Term
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.types import FloatArray

REFERENCE_PRESSURE = 1.0e6
"""Pressure (Pa) about which the load-dependent share is written."""


@dataclass(frozen=True, eq=False)
class LoadShareChange(Term):
    """A caliper force ``-A_eb p_b (s_1 u + s_2 u^2)`` held over each step.

    ``u = (p_b - p_ref) / p_ref``.
    """

    slope: FloatArray  # -, s_1
    curvature: FloatArray  # -, s_2

    def start(self, state: State) -> Step:
        """The force with each set's ``A_eb``."""
        bore_area = np.array([p.bore_area for p in state.params])
        return _LoadShare(self.slope, self.curvature, bore_area)


class _LoadShare(Step):
    def __init__(self, slope: FloatArray, curvature: FloatArray, bore_area: FloatArray) -> None:
        self.slope, self.curvature, self.bore_area = slope, curvature, bore_area

    def inputs(self, state: State, explicit: FloatArray) -> None:
        """The load-dependent part of the caliper's force."""
        p_b = state.value("p_b")
        u = (p_b - REFERENCE_PRESSURE) / REFERENCE_PRESSURE
        explicit[:, CALIPER_FORCE] += -self.bore_area * p_b * u * (self.slope + self.curvature * u)


@register_candidate_class
class EccentricLoad(Candidate):
    """Eccentric load: the caliper sees a share ``s`` of ``A_eb p_b``, not all of it.

    When the block's centre of force does not coincide with the pistons', the moment arms
    ``b_p``, ``b_k``, ``b_b``, ``b_c`` make the support columns carry part of the load, so the
    force on the caliper body is ``s A_eb p_b`` (the paper's eq. 22, five washers). The share
    may shift with load as the contact settles, to second order in the load about ``p_ref`` =
    1 MPa: ``s = 1 + s_0 + s_1 u + s_2 u^2``, ``u = (p_b - p_ref) / p_ref`` (a seating
    contact's share changes fastest at low load and levels off). It scales x_c and leaves p_b
    nearly alone.
    """

    entry = CATALOGUE["eccentric_load"]
    even_harmonics = True
    kin_forms = frozenset({("static_map", "x_c"), ("level_gain", "x_c")})  # x_c's gain vs load
    parameters = (
        CandidateParameter("share_offset", "-", -0.6, 0.6, 0.0),
        CandidateParameter("share_slope", "-", -0.4, 0.4, 0.0),
        CandidateParameter("share_curvature", "-", -0.2, 0.2, 0.0, absent=0.0),
    )

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Scale A_eb in the caliper's equation and add the load-dependent part."""
        draft.scale("bore_area", 1.0 + theta[:, 0])
        draft.add(LoadShareChange(theta[:, 1].copy(), theta[:, 2].copy()))

    def consistent(self, evidence: dict[str, float]) -> bool:
        """x_c is off by more than p_b."""
        return evidence.get("held_out_rms_x_c", 0.0) > 1.5 * evidence.get("held_out_rms_p_b", 0.0)
