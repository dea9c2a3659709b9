"""seal_stick_slip: the seal as a Jenkins element (spring and Coulomb slider)."""

from __future__ import annotations

import numpy as np

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
)
from brake_hil.diagnosis.candidates.registry import register_candidate_class
from brake_hil.diagnosis.engine import FrictionElement
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.types import FloatArray


@register_candidate_class
class SealStickSlip(Candidate):
    """Stick-slip seal friction in place of the equivalent viscous ``k_eh``, ``c_eh``.

    While the piston seal sticks it shears as a spring (both seals: ``k_j``, about ``2 k_s``,
    the paper's eq. 3); once its force reaches the static friction threshold (both seals: about
    ``2 F_fs = 2 mu_fs N_s``, eq. 2) it slips with that force and carries almost no stiffness
    (the paper's two-valued stiffness, section "Characterisation of k_eh"). A Jenkins element:
    an ideal spring in series with an ideal Coulomb slider. A share ``phi`` of the seal's
    response is frictional; the rest stays the calibrated equivalent spring and damper (a
    seal that slips over only part of its contact, or one whose rubber shears viscously).
    """

    entry = CATALOGUE["seal_stick_slip"]
    parameters = (
        CandidateParameter("seal_spring", "N/m", 2.0e6, 2.0e8, 2.3e7, logarithmic=True),
        CandidateParameter("slip_force", "N", 10.0, 3.0e3, 310.0, logarithmic=True),
        CandidateParameter("friction_share", "-", 0.05, 1.0, 0.7),
    )

    def start(self, context: Context) -> FloatArray:
        """Seed eqs. 2-3 for both seals."""
        return np.array(
            [2.0 * context.seal.static_stiffness, 2.0 * context.seal.friction_threshold, 0.7]
        )

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Replace the share phi of k_eh, c_eh by the Jenkins element."""
        share = theta[:, 2]
        draft.scale("effective_hydraulic_stiffness", 1.0 - share)
        draft.scale("effective_hydraulic_damping", 1.0 - share)
        draft.add(
            FrictionElement(
                spring=theta[:, 0] * share,
                apply_threshold=theta[:, 1] * share,
                release_threshold=theta[:, 1] * share,
            )
        )

    def consistent(self, evidence: dict[str, float]) -> bool:
        """Harmonics grow toward x_c, or k_eh falls with amplitude."""
        return evidence.get("harmonic_growth_x_c", 0.0) > 0.05 or (
            evidence.get("k_eh_trend", 0.0) < -0.05
        )
