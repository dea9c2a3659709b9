"""seal_groove_asymmetry: a seal stiffer on release than on apply."""

from __future__ import annotations

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
)
from brake_hil.types import FloatArray


class SealGrooveAsymmetry(Candidate):
    """Seal groove asymmetry: the seal pushes back harder on release than it yields on apply.

    Rectangular-seal grooves are chamfered on the pressure side, so the seal shears easily as
    the piston moves out and rolls it back more stiffly (the seed names the asymmetry and
    ignores it, section "Characterisation of k_eh"; Anwana, Cai and Chang, SAE 2002-01-0927).
    Modelled as the seal's equivalent spring with stiffness ``(1 - a) k_eh`` while its
    deflection from the relaxed position is on the apply side and ``(1 + a) k_eh`` on the
    release side, switching sharply; the relaxed position creeps toward the deflection with
    a first-order time constant ``tau_r``. Even harmonics appear in x_c and F_k.
    """

    name = "seal_groove_asymmetry"
    parameters = (
        CandidateParameter("stiffness_asymmetry", "-", -0.9, 0.9, 0.2),
        CandidateParameter("relaxation_time", "s", 0.05, 30.0, 1.0, logarithmic=True),
    )
    signature = "even harmonics (10, 20 Hz) in x_c and F_k; apply and release halves differ"

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """A bilinear seal spring about a creeping relaxed position."""
        draft.fields["stiffness_asymmetry"] = theta[:, 0].copy()
        draft.fields["relaxation_time"] = theta[:, 1].copy()

    def consistent(self, evidence: dict[str, float]) -> bool:
        """Even harmonics stand out in x_c or F_k."""
        return evidence.get("even_harmonics_x_c", 0.0) > 0.02 or (
            evidence.get("even_harmonics_F_k", 0.0) > 0.02
        )
