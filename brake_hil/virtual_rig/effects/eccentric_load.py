"""eccentric_load: the caliper sees a load-dependent share of the pressure force (eq. 22)."""

from __future__ import annotations

from dataclasses import dataclass

from brake_hil.physics import catalogue
from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.effects.registry import register_effect
from brake_hil.virtual_rig.laws import LtiPlant, Signal, TruthLaw


@dataclass(frozen=True)
class LoadDependentShare(TruthLaw):
    """Share of ``A_eb p_b`` that reaches the caliper, as a function of that force.

    The host's caliper-share port.
    """

    unloaded_change: float  # -, share - 1 at zero force
    loaded_change: float  # -, share - 1 at large force
    seating_force: float  # N, force at which half the change has gone

    def caliper_share(self, pressure_force: Signal) -> Signal:
        """``1 + d_1 + (d_0 - d_1) F_0 / (F_0 + F)`` (-) for the force ``F = A_eb p_b`` (N)."""
        force = fm.maximum(pressure_force, 0.0)
        share: Signal = (
            1.0
            + self.loaded_change
            + (self.unloaded_change - self.loaded_change)
            * self.seating_force
            / (self.seating_force + force)
        )
        return share


@register_effect
@dataclass(frozen=True)
class EccentricLoad(Effect):
    """Eccentric loading of the cut caliper.

    With washers under its mounting the caliper's pressure force and the support reaction no longer
    act along one line, and summing moments about the support point (seed eqs. 22a-c, ``F_c / F_p``
    set by the moment arms ``b_k``, ``b_b``, ``b_p``, ``d_b``, ``b_c`` and the washer stack
    ``(a - 1) w_w``) gives the caliper a different share of the pressure force than ``A_eb p_b``:
    less with five washers, which is why the seed over-predicts ``x_c`` by 7-39 % (Table 5), most
    at the lowest pressure. The simulator lets the share seat with load, as the contact of the
    washer stack and supports closes:
    ``F_c = A_eb p_b (1 + d_1 + (d_0 - d_1) F_0 / (F_0 + A_eb p_b))``, ``d_0`` unloaded and ``d_1``
    fully seated, scaled by ``strength``. Only the caliper's equation (21f) changes; the piston's
    (21e) keeps ``A_ep p_b``.
    Source: seed eq. 22 and Table 5.
    """

    strength: float = 1.0
    unloaded_share_change: float = -0.35
    loaded_share_change: float = -0.05
    seating_force: float = 3000.0

    entry = catalogue.entry("eccentric_load")
    parameters = (
        STRENGTH,
        Parameter("unloaded_share_change", "-", -0.6, 0.6, "d_0 at strength 1 (share - 1)"),
        Parameter("loaded_share_change", "-", -0.6, 0.6, "d_1 at strength 1 (share - 1)"),
        Parameter("seating_force", "N", 100.0, 1.0e5, "F_0 of the seating law"),
    )
    diagnosis_model = (
        "a caliper force share (A_eb replaced by s A_eb, eq. 22c) quadratic in p_b about "
        "1 MPa; the simulator's share seats with load hyperbolically, which the quadratic "
        "follows over the recorded pressures only"
    )

    def law(self, plant: LtiPlant) -> LoadDependentShare:
        """The seating law at this strength (caliper-share port; the same on every rig)."""
        del plant
        return LoadDependentShare(
            unloaded_change=self.strength * self.unloaded_share_change,
            loaded_change=self.strength * self.loaded_share_change,
            seating_force=self.seating_force,
        )
