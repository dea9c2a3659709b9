"""thermal_drift: line and seal properties drifting during the recording."""

from __future__ import annotations

import numpy as np

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
)
from brake_hil.types import FloatArray


class ThermalDrift(Candidate):
    """Thermal drift: viscosity and seal modulus change as the rig warms up.

    Brake-fluid viscosity falls steeply with temperature (Andrade, ``mu ~ exp(B / T)``) and
    the EPDM seal softens (its modulus has a temperature coefficient), so the line resistance
    (eq. 13) and the seal's ``k_eh``, ``c_eh`` drift during a long run. Over a recording the
    drift is taken as linear in time, one relative rate for the line resistance and one for
    the seal's ``k_eh`` and ``c_eh``, zero in the middle of the training data (where the
    calibration holds on average).
    """

    name = "thermal_drift"
    parameters = (
        CandidateParameter("line_drift_rate", "1/s", -0.08, 0.08, -0.005),
        CandidateParameter("seal_drift_rate", "1/s", -0.08, 0.08, -0.002),
    )
    signature = "the mismatch grows steadily over the recording, whatever the pressure"

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Scheduled drift of R, k_eh and c_eh."""
        draft.add("drift_rate", theta[:, 0])
        draft.add("seal_drift_rate", theta[:, 1])
        draft.fields["drift_reference"] = np.full(draft.batch, context.time_reference)

    def consistent(self, evidence: dict[str, float]) -> bool:
        """The residual changes over the recording."""
        return abs(evidence.get("drift", 0.0)) > 0.2
