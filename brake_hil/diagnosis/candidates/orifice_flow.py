"""orifice_flow: a turbulent, quadratic pressure drop across the needle valve."""

from __future__ import annotations

import numpy as np

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
)
from brake_hil.types import FloatArray


class OrificeFlow(Candidate):
    """Orifice flow: the needle valve drops pressure as ``K Q |Q|``, not ``R_v Q``.

    Past a throttling needle the flow separates and the drop follows the orifice equation,
    ``dp = rho Q |Q| / (2 C_d^2 A^2)`` (Merritt 1967, eq. 3-6; the seed linearises it,
    eqs. 15-16). Written as a share ``phi`` of the line resistance that becomes quadratic at
    the flow amplitude ``Q_0`` of the calibrated model: ``R (1 - phi) Q + phi R Q |Q| / Q_0``,
    so the drop is unchanged at ``Q_0`` and grows faster above it.
    """

    name = "orifice_flow"
    parameters = (CandidateParameter("turbulent_share", "-", 0.0, 0.95, 0.3),)
    signature = (
        "p_b's peak-to-peak is overpredicted more at large amplitudes than at small; p_b is "
        "flattened near its turning points"
    )

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Move a share of the line resistance into a quadratic drop."""
        share = theta[:, 0]
        resistance = np.array([p.line_resistance for p in draft.params])
        draft.scale("line_resistance", 1.0 - share)
        draft.add("orifice_coefficient", share * resistance / context.flow_amplitude)

    def consistent(self, evidence: dict[str, float]) -> bool:
        """The bore pressure is mispredicted."""
        return evidence.get("nrmse_p_b", 0.0) > 0.01
