"""orifice_flow: a turbulent, quadratic pressure drop across the needle valve."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
)
from brake_hil.diagnosis.candidates.registry import register_candidate_class
from brake_hil.diagnosis.engine import LINE_DROP, MidStep, State, Step, Term
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.types import FloatArray


@dataclass(frozen=True, eq=False)
class QuadraticDrop(Term):
    """A line pressure drop ``K Q |Q|`` at the valve, held over each step."""

    coefficient: FloatArray  # Pa s^2/m^6, K

    def start(self, state: State) -> Step:
        """The drop at the flow of each step's middle."""
        return _QuadraticDropStep(self.coefficient)


class _QuadraticDropStep(Step):
    def __init__(self, coefficient: FloatArray) -> None:
        self.coefficient = coefficient
        self.flow = MidStep()

    def inputs(self, state: State, explicit: FloatArray) -> None:
        """The drop at the flow through the valve in the middle of the step."""
        q = self.flow(state.line_flow())
        explicit[:, LINE_DROP] += self.coefficient * q * np.abs(q)


@register_candidate_class
class OrificeFlow(Candidate):
    """Orifice flow: the needle valve drops pressure as ``K Q |Q|``, not ``R_v Q``.

    Past a throttling needle the flow separates and the drop follows the orifice equation,
    ``dp = rho Q |Q| / (2 C_d^2 A^2)`` (Merritt 1967, eq. 3-6; the paper linearises it,
    eqs. 15-16). Written as a share ``phi`` of the line resistance that becomes quadratic at
    the flow amplitude ``Q_0`` of the calibrated model: ``R (1 - phi) Q + phi R Q |Q| / Q_0``,
    so the drop is unchanged at ``Q_0`` and grows faster above it.
    """

    entry = CATALOGUE["orifice_flow"]
    parameters = (CandidateParameter("turbulent_share", "-", 0.0, 0.95, 0.3),)

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Move a share of the line resistance into a quadratic drop."""
        share = theta[:, 0]
        resistance = np.array([p.line_resistance for p in draft.params])
        draft.scale("line_resistance", 1.0 - share)
        draft.add(QuadraticDrop(share * resistance / context.flow_amplitude))

    def consistent(self, evidence: dict[str, float]) -> bool:
        """The bore pressure is mispredicted."""
        return evidence.get("held_out_rms_p_b", 0.0) > 0.01
