"""thermal_drift: line and seal properties drifting during the recording."""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
    Rival,
)
from brake_hil.diagnosis.candidates.registry import register_candidate_class
from brake_hil.diagnosis.candidates.zero_wander import ZeroWander
from brake_hil.diagnosis.engine import Coupling, Entry, Term
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.types import FloatArray

FLOOR = 0.05
"""Smallest factor a drift may bring a coefficient to."""
LINEAR = 1.0e9
"""Heating time (s) of a drift linear in time over any recording (a model file's before it)."""


@dataclass(frozen=True, eq=False)
class HeatingDrift(Term):
    """The line resistance and the seal's ``k_eh``, ``c_eh`` drifting as the rig heats up.

    Each coefficient's factor is ``1 + r tau (exp(-t_0 / tau) - exp(-t / tau))``: it changes
    at the relative rate ``r exp(-t / tau)`` (``r`` at the recording's start ``t = 0``, falling
    as the temperature settles) and is 1 at the reference time ``t_0``; an infinite ``tau`` is
    a linear drift ``1 + r (t - t_0)`` (a model file older than ``tau`` has ``1e9`` s).
    """

    line_rate: FloatArray  # 1/s, relative drift rate of the line resistance at t = 0
    seal_rate: FloatArray  # 1/s, relative drift rate of k_eh and c_eh at t = 0
    reference: FloatArray  # s, recording time at which the drift is zero
    heating_time: FloatArray  # s, tau, the rig's heating time constant

    time_scheduled = True

    def couple(self, coupling: Coupling, row: int, entry: Entry) -> None:
        """The coefficients at the entry's time."""
        warmed = heated_time(entry.time, float(self.reference[row]), float(self.heating_time[row]))
        coupling.line_factor *= max(1.0 + float(self.line_rate[row]) * warmed, FLOOR)
        seal = max(1.0 + float(self.seal_rate[row]) * warmed, FLOOR)
        coupling.stiffness_factor *= seal
        coupling.damping_factor *= seal


def heated_time(time: float, reference: float, heating_time: float) -> float:
    """``tau (exp(-t_0 / tau) - exp(-t / tau))`` (s): ``t - t_0`` slowed as the rig settles.

    Times (s) from the recording's start; a long ``tau`` gives ``t - t_0``.
    """
    return heating_time * (
        math.expm1(-reference / heating_time) - math.expm1(-time / heating_time)
    )


@register_candidate_class
class ThermalDrift(Candidate):
    """Thermal drift: viscosity and seal modulus change as the rig warms up.

    Brake-fluid viscosity falls steeply with temperature (Andrade, ``mu ~ exp(B / T)``) and
    the EPDM seal softens (its modulus has a temperature coefficient), so the line resistance
    (eq. 13) and the seal's ``k_eh``, ``c_eh`` drift during a long run. The rig heats as a
    lumped thermal capacity cooled in proportion to its excess temperature (Newton), so from
    the recording's start its temperature approaches a plateau as ``1 - exp(-t / tau)``; over
    the few tens of kelvin of a run each coefficient is taken linear in temperature: one
    relative rate at the start for the line resistance and one for the seal's ``k_eh`` and
    ``c_eh``, one heating time ``tau``, zero change in the middle of the training data (where
    the calibration holds on average); a drift linear in time leaves several times more of a
    strong drift unexplained (evidence in docs/diagnosis.md). The rates at the start reach
    0.1 1/s on a fast heating (a viscosity falling by 64 % with a 7 s heating time).
    """

    entry = CATALOGUE["thermal_drift"]
    parameters = (
        CandidateParameter("line_drift_rate", "1/s", -0.25, 0.25, -0.005),
        CandidateParameter("seal_drift_rate", "1/s", -0.25, 0.25, -0.002),
        CandidateParameter("heating_time", "s", 1.0, 1000.0, 30.0, True, absent=LINEAR),
    )

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Scheduled drift of R, k_eh and c_eh."""
        reference = np.full(draft.batch, context.time_reference)
        draft.add(
            HeatingDrift(theta[:, 0].copy(), theta[:, 1].copy(), reference, theta[:, 2].copy())
        )

    def rivals(self, theta: FloatArray) -> tuple[Rival, ...]:
        """The force and displacement transducers' zeros moving within their stability.

        A seal softening moves the mean ``F_k`` and ``x_c``, as a walking zero does; a drift
        the recording shows only there is not told from the transducers.
        """
        return (ZeroWander(),)

    def consistent(self, evidence: dict[str, float]) -> bool:
        """The residual changes over the recording."""
        return abs(evidence.get("drift", 0.0)) > 0.2
