"""seal_groove_asymmetry: a seal stiffer on release than on apply."""

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
from brake_hil.diagnosis.engine import RELATIVE_FORCE, Coupling, Entry, State, Step, Term
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.types import FloatArray, IndexArray

APPLY, RELEASE = 0, 1


@dataclass(frozen=True, eq=False)
class BilinearSeal(Term):
    """The seal's spring, asymmetric about a creeping relaxed position.

    ``(1 - a) k_eh`` on the apply side of the relaxed position, ``(1 + a) k_eh`` on the
    release side.
    """

    asymmetry: FloatArray  # -, a
    relaxation_time: FloatArray  # s, creep of the relaxed position

    modes = 2  # APPLY, RELEASE

    def couple(self, coupling: Coupling, row: int, entry: Entry) -> None:
        """The side's stiffness."""
        a = float(self.asymmetry[row])
        coupling.stiffness_factor *= 1.0 - a if entry.mode == APPLY else 1.0 + a

    def start(self, state: State) -> Step:
        """Relaxed at the starting deflection, on the apply side."""
        stiffness = np.array([p.effective_hydraulic_stiffness for p in state.params])
        return _Relaxation(self, stiffness, state.seal())


class _Relaxation(Step):
    """The relaxed position and the side the seal is on."""

    def __init__(self, seal: BilinearSeal, stiffness: FloatArray, relaxed: FloatArray) -> None:
        self.seal, self.stiffness, self.relaxed = seal, stiffness, relaxed
        self.side: IndexArray = np.zeros(relaxed.size, dtype=np.intp)

    def mode(self) -> IndexArray:
        """APPLY or RELEASE per set."""
        return self.side

    def inputs(self, state: State, explicit: FloatArray) -> None:
        """Seal force k x_s - a k |x_s - x_r|: the tables carry k (1 -+ a) x_s, this the rest."""
        sign = np.where(self.side == APPLY, -1.0, 1.0)
        explicit[:, RELATIVE_FORCE] += sign * self.seal.asymmetry * self.stiffness * self.relaxed

    def update(self, state: State) -> None:
        """The relaxed position creeps toward the deflection; the side follows."""
        seal = state.seal()
        self.relaxed = (
            self.relaxed + (seal - self.relaxed) * state.sample_time / self.seal.relaxation_time
        )
        self.side = np.where(seal >= self.relaxed, APPLY, RELEASE)


@register_candidate_class
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

    entry = CATALOGUE["seal_groove_asymmetry"]
    lead_in = 3.0
    """s of history before the window: the seat creeps over a second or so, so a shorter run
    carries its start into the window and the fit makes the creep faster to forget it; 3 s
    recover the creep time (evidence in docs/diagnosis.md)."""
    parameters = (
        CandidateParameter("stiffness_asymmetry", "-", -0.9, 0.9, 0.2),
        CandidateParameter("relaxation_time", "s", 0.05, 30.0, 1.0, logarithmic=True),
    )

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """A bilinear seal spring about a creeping relaxed position."""
        draft.add(BilinearSeal(theta[:, 0].copy(), theta[:, 1].copy()))

    def consistent(self, evidence: dict[str, float]) -> bool:
        """Even harmonics stand out in x_c or F_k."""
        return evidence.get("even_harmonics_x_c", 0.0) > 0.02 or (
            evidence.get("even_harmonics_F_k", 0.0) > 0.02
        )
