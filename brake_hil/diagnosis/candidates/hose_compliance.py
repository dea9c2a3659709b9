"""hose_compliance: an extra RC stage for the hose between master cylinder and bore."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
)
from brake_hil.diagnosis.engine import Coupling, Entry, Term
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.types import FloatArray


@dataclass(frozen=True, eq=False)
class HoseNode(Term):
    """A node of compliance ``C_h`` between the pipe and valve and the hose."""

    compliance: FloatArray  # m^3/Pa, C_h
    resistance_share: FloatArray  # -, part of the line resistance beyond the node

    linear = True

    def couple(self, coupling: Coupling, row: int, entry: Entry) -> None:
        """Split the line at the node."""
        coupling.hose_compliance = float(self.compliance[row])
        coupling.hose_resistance_share = float(self.resistance_share[row])


class HoseCompliance(Candidate):
    """Hose compliance: the line stores fluid as its walls swell.

    The seed folds the pipe's and hose's wall compliance into the bore's effective bulk
    modulus (eq. 18) and neglects it in the flow equation (eq. 21c). A braided hose's
    swelling is a compliance of its own between the valve and the bore: one lumped node of
    compliance ``C_h`` that splits the line into an upstream part (pipe and valve: their
    resistance, eq. 13, and 70 % of the inertance) and a downstream one (the hose's own
    resistance ``R_t`` and the rest) (Merritt 1967, ch. 4, lumped transmission line).
    """

    entry = CATALOGUE["hose_compliance"]
    parameters = (
        CandidateParameter("hose_compliance_ratio", "-", 0.02, 20.0, 0.5, logarithmic=True),
    )

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """A hose node whose compliance is a multiple of the bore's."""
        compliance = np.array([p.bore_compliance for p in draft.params])
        share = np.full(len(draft.params), context.hose_resistance_share)
        draft.add(HoseNode(theta[:, 0] * compliance, share))

    def consistent(self, evidence: dict[str, float]) -> bool:
        """The bore pressure is mispredicted."""
        return evidence.get("nrmse_p_b", 0.0) > 0.01
