"""thermal_drift: line and seal properties drifting during the recording."""

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

FLOOR = 0.05
"""Smallest factor a drift may bring a coefficient to."""


@dataclass(frozen=True, eq=False)
class LinearDrift(Term):
    """The line resistance and the seal's ``k_eh``, ``c_eh`` drifting linearly in time."""

    line_rate: FloatArray  # 1/s, relative drift of the line resistance
    seal_rate: FloatArray  # 1/s, relative drift of k_eh and c_eh
    reference: FloatArray  # s, recording time at which the drift is zero

    time_scheduled = True

    def couple(self, coupling: Coupling, row: int, entry: Entry) -> None:
        """The coefficients at the entry's time."""
        elapsed = entry.time - float(self.reference[row])
        line = max(1.0 + float(self.line_rate[row]) * elapsed, FLOOR)
        seal = max(1.0 + float(self.seal_rate[row]) * elapsed, FLOOR)
        coupling.line_factor *= line
        coupling.stiffness_factor *= seal
        coupling.damping_factor *= seal


class ThermalDrift(Candidate):
    """Thermal drift: viscosity and seal modulus change as the rig warms up.

    Brake-fluid viscosity falls steeply with temperature (Andrade, ``mu ~ exp(B / T)``) and
    the EPDM seal softens (its modulus has a temperature coefficient), so the line resistance
    (eq. 13) and the seal's ``k_eh``, ``c_eh`` drift during a long run. Over a recording the
    drift is taken as linear in time, one relative rate for the line resistance and one for
    the seal's ``k_eh`` and ``c_eh``, zero in the middle of the training data (where the
    calibration holds on average).
    """

    entry = CATALOGUE["thermal_drift"]
    parameters = (
        CandidateParameter("line_drift_rate", "1/s", -0.08, 0.08, -0.005),
        CandidateParameter("seal_drift_rate", "1/s", -0.08, 0.08, -0.002),
    )

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Scheduled drift of R, k_eh and c_eh."""
        reference = np.full(draft.batch, context.time_reference)
        draft.add(LinearDrift(theta[:, 0].copy(), theta[:, 1].copy(), reference))

    def consistent(self, evidence: dict[str, float]) -> bool:
        """The residual changes over the recording."""
        return abs(evidence.get("drift", 0.0)) > 0.2
