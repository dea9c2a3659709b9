"""hose_compliance: an extra RC stage for the hose between master cylinder and bore."""

from __future__ import annotations

import numpy as np

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
)
from brake_hil.types import FloatArray


class HoseCompliance(Candidate):
    """Hose compliance: the line stores fluid as its walls swell.

    The seed folds the pipe's and hose's wall compliance into the bore's effective bulk
    modulus (eq. 18) and neglects it in the flow equation (eq. 21c). A braided hose's
    swelling is a compliance of its own between the valve and the bore: one lumped node of
    compliance ``C_h`` that splits the line into an upstream part (pipe and valve: their
    resistance, eq. 13, and 70 % of the inertance) and a downstream one (the hose's own
    resistance ``R_t`` and the rest) (Merritt 1967, ch. 4, lumped transmission line).
    """

    name = "hose_compliance"
    parameters = (
        CandidateParameter("hose_compliance_ratio", "-", 0.02, 20.0, 0.5, logarithmic=True),
    )
    signature = "p_b lags p_i more than the model predicts; its amplitude drops; x_c follows"

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """A hose node whose compliance is a multiple of the bore's."""
        compliance = np.array([p.bore_compliance for p in draft.params])
        draft.add("hose_compliance", theta[:, 0] * compliance)
        share = np.full(len(draft.params), context.hose_resistance_share)
        draft.add("hose_resistance_share", share)

    def consistent(self, evidence: dict[str, float]) -> bool:
        """The bore pressure is mispredicted."""
        return evidence.get("nrmse_p_b", 0.0) > 0.01
