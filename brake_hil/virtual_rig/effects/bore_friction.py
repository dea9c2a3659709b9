"""bore_friction: Coulomb friction where the cocked caliper presses the piston on its bore."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from brake_hil.physics import catalogue
from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.effects.registry import register_effect
from brake_hil.virtual_rig.laws import LtiPlant, Signal, State
from brake_hil.virtual_rig.mechanics import CockedContact, smooth_speed


@dataclass(frozen=True)
class DahlBoreFriction(CockedContact):
    """Piston-bore friction bound to a rig (SI): the host's bore-force port, state ``w``."""

    static_coefficient: float  # mu_s, -
    kinetic_ratio: float  # mu_k / mu_s, -
    stribeck_velocity: float  # v_S, m/s
    presliding_displacement: float  # delta, m
    guide_length: float  # l_g, m
    bore_area: float  # A_eb, m^2

    def coefficient(self, velocity: Signal) -> Signal:
        """Stribeck friction coefficient ``mu_k + (mu_s - mu_k) exp(-(v/v_S)^2)`` (-)."""
        kinetic = self.kinetic_ratio * self.static_coefficient
        decay = fm.exp(-((velocity / self.stribeck_velocity) ** 2))
        mu: Signal = kinetic + (self.static_coefficient - kinetic) * decay
        return mu

    def state_rate(self, state: Signal, velocity: Signal) -> Signal:
        """Dahl's normalised pre-sliding state ``w' = (v - |v| w) / delta`` (1/s)."""
        rate: Signal = (velocity - smooth_speed(velocity) * state) / (self.presliding_displacement)
        return rate

    def force(
        self,
        state: Signal,
        velocity: Signal,
        bore_pressure: Signal,
        caliper_displacement: Signal,
    ) -> Signal:
        """Friction on the piston ``mu_s N w``, opposing the seal velocity ``x_p' - x_c'`` (N)."""
        del velocity  # the Stribeck curve acts through the state
        force: Signal = (
            self.static_coefficient
            * self.normal_force(bore_pressure, caliper_displacement)
            * state
        )
        return force

    def states(self) -> tuple[State, ...]:
        """Dahl's normalised pre-sliding state ``w`` (-)."""
        return (State("w", 1.0),)

    def initial_state(self, equilibrium: Mapping[str, float]) -> tuple[float, ...]:
        """At rest the contact has not slid: ``w = 0``."""
        del equilibrium
        return (0.0,)

    def bore_force(
        self,
        velocity: Signal,
        bore_pressure: Signal,
        caliper_displacement: Signal,
        states: Sequence[Signal],
    ) -> tuple[Signal, list[Signal]]:
        """Friction on the piston (N) and ``w'`` (1/s)."""
        w = states[0]
        force = self.force(w, velocity, bore_pressure, caliper_displacement)
        return force, [self.state_rate(w, velocity)]


@register_effect
@dataclass(frozen=True)
class BoreFriction(Effect):
    """Piston-bore friction from caliper cocking.

    Under load the cut caliper tilts, the piston bears on its bore at two edges and Coulomb
    friction opposes the piston's slide relative to the bore, a force proportional to ``p_b x_c``
    (seed eqs. 8-9, ``F_fb = 4 mu_fb A_eb p_b x_c / l_c``). It dissipates energy per cycle and so
    adds damping (``c_fb``). The simulator takes the contact force over the piston's guide length
    ``l_g`` (the couple's real arm) instead of the transducer distance ``l_c``, uses Dahl's
    pre-sliding law (``w' = (v - |v| w mu_s / mu(v)) / delta``, ``F = mu_s N w``; Dahl, "A solid
    friction model", Aerospace Corp. TOR-0158(3107-18)-1, 1968) with a Stribeck coefficient
    ``mu(v) = mu_k + (mu_s - mu_k) exp(-(v / v_S)^2)`` inside it (as in LuGre),
    ``mu_s = strength mu_fb``.
    Source: seed eqs. 8-9; Dahl (1968).
    """

    strength: float = 1.0
    guide_length: float = 3.0e-3
    presliding_displacement: float = 1.0e-6
    kinetic_ratio: float = 0.7
    stribeck_velocity: float = 1.0e-3

    entry = catalogue.entry("bore_friction")
    parameters = (
        STRENGTH,
        Parameter("guide_length", "m", 1.0e-3, 0.05, "l_g, arm of the cocking couple"),
        Parameter("presliding_displacement", "m", 1.0e-8, 1.0e-5, "delta of Dahl's law"),
        Parameter("kinetic_ratio", "-", 0.3, 1.0, "mu_k / mu_s"),
        Parameter("stribeck_velocity", "m/s", 1.0e-5, 0.1, "v_S of the Stribeck curve"),
    )
    diagnosis_model = (
        "ideal Coulomb friction F = mu N sign(x_s') with N ~ p_b |x_c| (eqs. 8-9) or its "
        "equivalent viscous c_fb; the simulator has pre-sliding (Dahl), a Stribeck "
        "coefficient and the guide-length arm"
    )

    def law(self, plant: LtiPlant) -> DahlBoreFriction:
        """The friction of the plant's truth bore at this strength."""
        rig = plant.rig
        return DahlBoreFriction(
            static_coefficient=self.strength * rig.bore_friction_coefficient,
            kinetic_ratio=self.kinetic_ratio,
            stribeck_velocity=self.stribeck_velocity,
            presliding_displacement=self.presliding_displacement,
            guide_length=self.guide_length,
            bore_area=plant.params.bore_area,
        )

    def install(self, plant: LtiPlant) -> DahlBoreFriction | None:
        """Bore-force port: friction in parallel with the seals (none on a frictionless bore)."""
        if not self.active or plant.rig.bore_friction_coefficient == 0.0:
            return None
        return self.law(plant)
