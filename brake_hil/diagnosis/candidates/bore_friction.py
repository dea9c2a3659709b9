"""bore_friction: Coulomb friction at the piston-bore contact from caliper cocking."""

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

CONTACT_STIFFNESS = 5.0e7
"""Tangential stiffness of the piston-bore contact before it slides (N/m), of a model file
written before the candidate fitted it."""


@register_candidate_class
class BoreFriction(Candidate):
    """Bore friction: the cocked caliper presses the pistons against their bores.

    As the caliper rotates by ``x_c / l_c`` the bore wall pushes on the piston with a normal
    force ``2 N_b = 4 A_eb p_b |x_c| / l_c``; sliding against it costs Coulomb friction
    ``F_fb = mu_fb 4 A_eb p_b |x_c| / l_c`` (eq. 8). Modelled as a contact spring in series
    with a slider whose threshold follows that force, in parallel with the seal.

    Fitted: the coefficient, ``mu_fb`` times ``l_c`` over the arm the cocking couple acts on
    (the paper takes ``l_c``, 10 cm; over a piston's guide of a few millimetres the bore
    presses some 30 times harder, so up to 30), and the contact's tangential stiffness before
    it slides (pre-sliding: a Dahl contact's, 1e6-1e11 N/m; a rigid one at the top).
    """

    entry = CATALOGUE["bore_friction"]
    even_harmonics = True  # its friction grows with the pressure on the seal
    parameters = (
        CandidateParameter("bore_friction_coefficient", "-", 0.0, 30.0, 0.2),
        CandidateParameter(
            "contact_stiffness",
            "N/m",
            1.0e6,
            1.0e11,
            1.0e9,
            logarithmic=True,
            absent=CONTACT_STIFFNESS,
        ),
    )

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """A slider whose threshold is mu 4 A_eb p_b |x_c| / l_c.

        It acts on the seal's slider, if there is one.
        """
        bore_area = np.array([p.bore_area for p in draft.params])
        draft.add(
            FrictionElement(
                spring=theta[:, 1].copy(),
                apply_threshold=np.zeros(draft.batch),
                release_threshold=np.zeros(draft.batch),
                bore_friction=4.0 * theta[:, 0] * bore_area / context.transducer_distance,
                contact=True,
            )
        )

    def consistent(self, evidence: dict[str, float]) -> bool:
        """The caliper or block channel is mispredicted."""
        return (
            max(evidence.get("held_out_rms_x_c", 0.0), evidence.get("held_out_rms_F_k", 0.0))
            > 0.01
        )
