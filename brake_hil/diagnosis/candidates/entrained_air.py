"""entrained_air: isothermal air whose compliance falls with pressure."""

from __future__ import annotations

from dataclasses import dataclass

from brake_hil.diagnosis.candidates.base import (
    Candidate,
    CandidateParameter,
    Context,
    Draft,
)
from brake_hil.diagnosis.candidates.registry import register_candidate_class
from brake_hil.diagnosis.engine import Coupling, Entry, Term
from brake_hil.diagnosis.thresholds import NOISE_EXCESS, SIGNIFICANT_Z
from brake_hil.physics.catalogue import CATALOGUE
from brake_hil.types import FloatArray

ATMOSPHERE = 1.013e5
"""Absolute pressure of gauge zero (Pa)."""


@dataclass(frozen=True, eq=False)
class IsothermalAir(Term):
    """Air in the bore chamber: compliance ``V_0 p_atm / p_abs^2`` on top of ``C_b``."""

    volume: FloatArray  # m^3, air volume at gauge zero

    pressure_scheduled = True

    def couple(self, coupling: Coupling, row: int, entry: Entry) -> None:
        """The air's compliance at the entry's bore pressure."""
        absolute = max(entry.pressure, 0.0) + ATMOSPHERE
        coupling.extra_compliance += float(self.volume[row]) * ATMOSPHERE / absolute**2


@register_candidate_class
class EntrainedAir(Candidate):
    """Entrained air: a bulk modulus that rises with pressure.

    Air bubbles in the fluid compress isothermally (Boyle), so their volume ``V_a = j V_b
    p_atm / p_abs`` and the bore chamber's compliance gains ``j V_b p_atm / p_abs^2``: soft at
    low pressure, stiff at high (the paper's eq. 18 linearises it at the mean pressure; Merritt,
    Hydraulic Control Systems, 1967, section 2.5). ``j`` is the air's volume share at gauge
    zero beyond what the calibrated compliance holds.
    """

    entry = CATALOGUE["entrained_air"]
    even_harmonics = True
    parameters = (CandidateParameter("air_share", "-", 1.0e-4, 0.2, 5.0e-3, logarithmic=True),)

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Pressure-scheduled bore compliance."""
        draft.add(IsothermalAir(theta[:, 0] * context.bore_volume))

    def consistent(self, evidence: dict[str, float]) -> bool:
        """The bore pressure carries even harmonics the baseline does not make, beyond noise.

        Air's compliance falls with the pressure, so the bore is softer on the cycle's low
        half than on its high half: even harmonics of ``p_b``, judged against their own
        scatter over the cycles and the noise (``evidence.even_harmonics_z``, the bars of
        :func:`.summary.unmade_signature`), not against a fixed share of the peak-to-peak (a
        little air mispredicts ``p_b`` by well under 1 %); or ``p_b`` mispredicted by over
        1 % (``evidence.MISMATCH_RMS``: segments under 16 cycles, too short for 8 pieces of
        two cycles, show no scatter of their even harmonics).
        """
        noise = evidence.get("noise_nrmse", 0.0) ** 2
        even = (
            evidence.get("even_harmonics_z_p_b", 0.0) > SIGNIFICANT_Z
            and evidence.get("even_harmonics_power_p_b", 0.0) > NOISE_EXCESS * noise
        )
        return even or evidence.get("held_out_rms_p_b", 0.0) > 0.01  # evidence.MISMATCH_RMS
