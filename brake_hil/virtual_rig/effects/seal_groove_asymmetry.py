"""seal_groove_asymmetry: the seal behaves differently on apply and on release."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

from brake_hil.virtual_rig.effects import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter, Signal

if TYPE_CHECKING:
    from brake_hil.virtual_rig.plant import Plant


def asymmetric_spring(deflection: Signal, asymmetry: float, width: float) -> Signal:
    """Effective deflection (m) of a spring that is ``(1 - a)`` as stiff on the apply side
    (``e > 0``) as on average and ``(1 + a)`` on the release side: ``e - a e tanh(e / w)``."""
    effective: Signal = deflection - asymmetry * deflection * fm.tanh(deflection / width)
    return effective


@dataclass(frozen=True)
class SealGrooveAsymmetry(Effect):
    """Seal-groove asymmetry: the groove's chamfer on the pressure side lets the rectangular
    seal shear easily as the piston moves out (apply) and makes it push back harder as the
    piston returns (release, the seal's "rollback"), so the seal's stiffness and its slip
    threshold differ between the two directions (Anwana, Cai, Chang, "Analysis of brake
    caliper seal-groove design", SAE 2002-01-0927). On the equivalent spring ``k_eh`` the
    simulator measures the seal's deflection ``e`` from its slowly creeping relaxed position
    ``x_r`` (``x_r' = e / tau_r``) and gives it stiffness ``(1 - a) k_eh`` on the apply side
    and ``(1 + a) k_eh`` on the release side, smoothly:
    ``F = k_eh (x_r + e - a e tanh(e / w))``; on a frictional seal (seal_stick_slip) the slip
    threshold is ``(1 - a) g(v)`` on apply and ``(1 + a) g(v)`` on release.
    Source: the seed's list of physics its LTI model leaves out; Anwana et al. (2002).
    """

    strength: float = 1.0
    asymmetry: float = 0.4
    relaxation_time: float = 1.0

    name = "seal_groove_asymmetry"
    parameters = (
        STRENGTH,
        Parameter("asymmetry", "-", 0.05, 0.8, "a at strength 1: apply (1 - a), release (1 + a)"),
        Parameter("relaxation_time", "s", 0.05, 20.0, "tau_r, creep of the relaxed position"),
    )
    signature = (
        "an even (2nd) harmonic in x_c and F_k that p_i lacks, a lopsided x_c waveform "
        "(apply half longer than release half), the mean x_c shifted from the static value"
    )
    diagnosis_model = (
        "a bilinear seal stiffness (k_apply, k_release) switching on the sign of the seal "
        "velocity, or a Jenkins slider with two thresholds; the simulator switches smoothly "
        "about a creeping relaxed position, not on the velocity"
    )

    def install(self, plant: Plant) -> Plant:
        """Seal slot: asymmetry ``strength * asymmetry`` with its relaxation time."""
        if not self.active:
            return plant
        seal = replace(
            plant.seal,
            asymmetry=self.strength * self.asymmetry,
            relaxation_time=self.relaxation_time,
        )
        return replace(plant, seal=seal)
