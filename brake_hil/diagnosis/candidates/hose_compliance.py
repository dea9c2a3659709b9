"""hose_compliance: an extra RC stage for the hose between master cylinder and bore."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
    Rival,
)
from brake_hil.diagnosis.candidates.late_input import LateInput
from brake_hil.diagnosis.candidates.registry import register_candidate_class
from brake_hil.diagnosis.engine import Coupling, Entry, Term
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.types import FloatArray


@dataclass(frozen=True, eq=False)
class HoseNode(Term):
    """A node of compliance ``C_h`` between the pipe and valve and the hose; its wall creeps."""

    compliance: FloatArray  # m^3/Pa, C_h, the part stored at once
    resistance_share: FloatArray  # -, part of the line resistance beyond the node
    creep_compliance: FloatArray  # m^3/Pa, C_d, the wall's retarded part
    creep_time: FloatArray  # s, tau_w, its retardation time

    linear = True

    def couple(self, coupling: Coupling, row: int, entry: Entry) -> None:
        """Split the line at the node; the node's wall swells partly with a delay."""
        coupling.hose_compliance = float(self.compliance[row])
        coupling.hose_resistance_share = float(self.resistance_share[row])
        coupling.hose_creep_compliance = float(self.creep_compliance[row])
        coupling.hose_creep_time = float(self.creep_time[row])


@register_candidate_class
class HoseCompliance(Candidate):
    """Hose compliance: the line stores fluid as its walls swell.

    The paper folds the pipe's and hose's wall compliance into the bore's effective bulk
    modulus (eq. 18) and neglects it in the flow equation (eq. 21c). A braided hose's
    swelling is a compliance of its own between the valve and the bore: one lumped node of
    compliance ``C_h`` that splits the line into an upstream part (pipe and valve: their
    resistance, eq. 13, and 70 % of the inertance) and a downstream one (the hose's own
    resistance ``R_t`` and the rest) (Merritt 1967, ch. 4, lumped transmission line). A
    rubber hose wall is viscoelastic: part of its swell ``C_d`` follows the pressure with a
    retardation time ``tau_w`` (a Kelvin-Voigt element; Covas et al., J. Hydraulic Research
    42(5), 2004), so the stored volume and the bore pressure's lag depend on the frequency.
    The wall's swell does not change with pressure (SAE J1401 rates a brake hose by one
    volumetric expansion per pressure and length), unlike the bore's compliance, which the air
    sets (eq. 18): so ``C_h`` is a multiple of one fixed compliance, the rig file's ``C_b``
    at 0.9 MPa, not of each segment's ``C_b``, which fits the hoses of both families more
    closely (evidence in docs/diagnosis.md).
    """

    entry = CATALOGUE["hose_compliance"]
    own_rig_values = (("hose_stiffness", -1),)  # a hose that swells more has a softer wall
    retired_parameters = ("hose_compliance_ratio",)  # a multiple of each segment's C_b
    parameters = (
        CandidateParameter("hose_wall_ratio", "-", 0.02, 20.0, 0.5, logarithmic=True),
        CandidateParameter("hose_creep_ratio", "-", 0.01, 5.0, 0.3, True, absent=0.0),
        CandidateParameter("hose_creep_time", "s", 0.002, 0.3, 0.02, True, absent=0.02),
    )

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """A hose node of a fixed multiple of the reference compliance, part of it retarded."""
        compliance = theta[:, 0] * context.reference_compliance
        share = np.full(len(draft.params), context.hose_resistance_share)
        draft.add(HoseNode(compliance, share, theta[:, 1] * compliance, theta[:, 2]))

    def rivals(self, theta: FloatArray) -> tuple[Rival, ...]:
        """``p_i`` acquired late through its filter (every output leading alike).

        With the creeping wall, a hose plus a calibration of less lag of its own mimics a late
        ``p_i`` (a creep ratio at its bound, a retardation of tens of ms; evidence in
        docs/diagnosis.md).
        """
        return (LateInput(),)

    def consistent(self, evidence: dict[str, float]) -> bool:
        """The bore pressure is mispredicted."""
        return evidence.get("held_out_rms_p_b", 0.0) > 0.01
