"""eccentric_load: the caliper takes a load-dependent share of the pressure force."""

from __future__ import annotations

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
)
from brake_hil.types import FloatArray


class EccentricLoad(Candidate):
    """Eccentric load: the caliper sees a share ``s`` of ``A_eb p_b``, not all of it.

    When the block's centre of force does not coincide with the pistons', the moment arms
    ``b_p``, ``b_k``, ``b_b``, ``b_c`` make the support columns carry part of the load, so the
    force on the caliper body is ``s A_eb p_b`` (seed eq. 22, five-washer results). The share
    may shift with load as the contact settles: ``s = 1 + s_0 + s_1 (p_b - p_ref) / p_ref``,
    ``p_ref`` = 1 MPa. It scales x_c and leaves p_b nearly alone.
    """

    name = "eccentric_load"
    parameters = (
        CandidateParameter("share_offset", "-", -0.6, 0.6, 0.0),
        CandidateParameter("share_slope", "-", -0.4, 0.4, 0.0),
    )
    signature = "x_c's amplitude is mispredicted while p_b is right; the error grows with load"

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Scale A_eb in the caliper's equation and add the load-dependent part."""
        draft.scale("bore_area", 1.0 + theta[:, 0])
        draft.add("share_slope", theta[:, 1])

    def consistent(self, evidence: dict[str, float]) -> bool:
        """x_c is off by more than p_b."""
        return evidence.get("nrmse_x_c", 0.0) > 1.5 * evidence.get("nrmse_p_b", 0.0)
