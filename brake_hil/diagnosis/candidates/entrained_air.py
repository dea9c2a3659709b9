"""entrained_air: isothermal air whose compliance falls with pressure."""

from __future__ import annotations

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
)
from brake_hil.types import FloatArray


class EntrainedAir(Candidate):
    """Entrained air: a bulk modulus that rises with pressure.

    Air bubbles in the fluid compress isothermally (Boyle), so their volume ``V_a = j V_b
    p_atm / p_abs`` and the bore chamber's compliance gains ``j V_b p_atm / p_abs^2``: soft at
    low pressure, stiff at high (seed eq. 18 linearises it at the mean pressure; Merritt,
    Hydraulic Control Systems, 1967, section 2.5). ``j`` is the air's volume share at gauge
    zero beyond what the calibrated compliance holds.
    """

    name = "entrained_air"
    parameters = (CandidateParameter("air_share", "-", 1.0e-4, 0.2, 5.0e-3, logarithmic=True),)
    signature = (
        "p_b lags and drops more at low pressure than at high; the mismatch in p_b changes "
        "with the segment's mean pressure; super-harmonics in p_b"
    )

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Pressure-scheduled bore compliance."""
        draft.add("air_volume", theta[:, 0] * context.bore_volume)

    def consistent(self, evidence: dict[str, float]) -> bool:
        """The bore pressure is mispredicted."""
        return evidence.get("nrmse_p_b", 0.0) > 0.01
