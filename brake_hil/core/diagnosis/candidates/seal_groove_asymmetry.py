"""seal_groove_asymmetry: a Jenkins seal whose slip threshold differs by direction."""

from __future__ import annotations

import numpy as np

from brake_hil.core.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
)
from brake_hil.core.diagnosis.candidates.seal_stick_slip import SealStickSlip
from brake_hil.core.types import FloatArray


class SealGrooveAsymmetry(Candidate):
    """Seal groove asymmetry: the seal slips at a different force on apply than on release.

    Rectangular-seal grooves are chamfered on the pressure side, so the seal rolls back less
    freely than it is pushed forward (the seed ignores this, section "Characterisation of
    k_eh"; Anwana, Cai and Wang, SAE 2002-01-2588). Modelled as the stick-slip seal (Jenkins
    element) with thresholds ``F (1 + a)`` while applying and ``F (1 - a)`` while releasing:
    the loop loses its point symmetry and even harmonics appear in x_c and F_k.
    """

    name = "seal_groove_asymmetry"
    parameters = (
        *SealStickSlip.parameters,
        CandidateParameter("asymmetry", "-", -0.9, 0.9, 0.2),
    )
    signature = "even harmonics (10, 20 Hz) in x_c and F_k; apply and release edges differ"

    def start(self, context: Context) -> FloatArray:
        """The stick-slip start with a modest asymmetry."""
        return np.append(SealStickSlip().start(context), 0.2)

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """The Jenkins seal with direction-dependent thresholds."""
        SealStickSlip().fill(draft, theta[:, :2], context)
        asymmetry = theta[:, 2]
        draft.fields["apply_threshold"] = draft.fields["apply_threshold"] * (1.0 + asymmetry)
        draft.fields["release_threshold"] = draft.fields["release_threshold"] * (1.0 - asymmetry)

    def consistent(self, evidence: dict[str, float]) -> bool:
        """Even harmonics stand out in x_c or F_k."""
        return evidence.get("even_harmonics_x_c", 0.0) > 0.05 or (
            evidence.get("even_harmonics_F_k", 0.0) > 0.05
        )
