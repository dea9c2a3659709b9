"""seal_stick_slip: the piston seals stick and slip instead of acting as ``k_eh``, ``c_eh``."""

from __future__ import annotations

from dataclasses import dataclass
import math

from brake_hil.physics import catalogue
from brake_hil.physics.parameters import seal_properties
from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.effects.registry import register_effect
from brake_hil.virtual_rig.laws import LtiPlant, SealPorts, Signal
from brake_hil.virtual_rig.mechanics import (
    ASYMMETRY_WIDTH_SHARE,
    FrictionalSeal,
    asymmetric_limit,
    smooth_speed,
    structural_damping,
)


@dataclass(frozen=True)
class LuGreSeal(FrictionalSeal):
    """LuGre friction law of both seals together, bound to a rig (SI).

    The host's seal-force port (state ``z``, the seals' shear deflection) and structural damping.
    """

    bristle_stiffness: float  # sigma_0 = 2 k_s, N/m
    static_force: float  # F_S = 2 F_fs, N
    coulomb_force: float  # F_C, N
    stribeck_velocity: float  # v_S, m/s
    microdamping: float  # sigma_1, N s/m
    viscous_friction: float  # sigma_2, N s/m
    share: float = 1.0  # -, share of the seal force this law carries (the rest: k_eh, c_eh)
    caliper_damping: float = 0.0  # N s/m, caliper to ground, kept where c_eh is replaced
    block_damping: float = 0.0  # N s/m, piston to block (load cells)

    def slip_force(
        self, velocity: Signal, deflection: Signal, asymmetry: float, modulus_factor: Signal
    ) -> Signal:
        """Stribeck curve ``g(v)`` (N), scaled by the side of the seal's deflection.

        Times ``(1 - a)`` on the apply side of the seal's deflection (``z > 0``) and ``(1 + a)`` on
        the release side, switched smoothly.
        """
        decay = fm.exp(-((velocity / self.stribeck_velocity) ** 2))
        slip = (self.coulomb_force + (self.static_force - self.coulomb_force) * decay) * (
            modulus_factor
        )
        if asymmetry:
            width = ASYMMETRY_WIDTH_SHARE * self.static_force / self.bristle_stiffness
            slip = asymmetric_limit(slip, asymmetry, deflection, width)
        return slip

    def deflection_rate(
        self, deflection: Signal, velocity: Signal, slip_force: Signal, modulus_factor: Signal
    ) -> Signal:
        """``z' = v - sigma_0 |v| z / g`` (m/s): the seal shears, then slides."""
        stiffness = self.bristle_stiffness * modulus_factor
        return velocity - stiffness * smooth_speed(velocity) * deflection / slip_force

    def force(
        self,
        deflection: Signal,
        deflection_rate: Signal,
        velocity: Signal,
        modulus_factor: Signal,
        viscosity_factor: Signal,
    ) -> Signal:
        """Seal force on the piston ``sigma_0 z + sigma_1 z' + sigma_2 v`` (N)."""
        return (
            self.bristle_stiffness * modulus_factor * deflection
            + self.microdamping * deflection_rate
            + self.viscous_friction * viscosity_factor * velocity
        )

    def rest_limit(self) -> float:
        """At rest the seals are sheared below their slip limit (m)."""
        return 0.99 * self.coulomb_force / self.bristle_stiffness

    def own_force(self, deflection: Signal, seal: SealPorts) -> tuple[Signal, Signal]:
        """The LuGre force (N) and ``z'`` (m/s)."""
        velocity, modulus = seal.velocity, seal.modulus_factor
        slip = self.slip_force(velocity, deflection, seal.asymmetry, modulus)
        z_rate = self.deflection_rate(deflection, velocity, slip, modulus)
        friction = self.force(deflection, z_rate, velocity, modulus, seal.viscosity_factor)
        return friction, z_rate


@register_effect
@dataclass(frozen=True)
class SealStickSlip(Effect):
    """Seal stick-slip: Coulomb friction at the piston-seal interface.

    It takes the place of the equivalent viscous ``k_eh``, ``c_eh``. Each rectangular seal is a
    shear beam of stiffness ``k_s = G_s pi d_p w_s / l_s`` (seed eq. 3) whose inner face sticks to
    the piston until the shear force reaches ``F_fs = mu_fs E_s eps_s pi d_p w_s`` (seed eq. 2),
    then slides; the seed's Table 3 (``k_eh`` falling with amplitude) and Table 1 (super-harmonics
    growing toward ``x_c``) are its signatures. The simulator writes it as a LuGre law (Canudas de
    Wit, Olsson, Astrom, Lischinsky, IEEE Trans. Automatic Control 40(3), 1995) whose bristle is
    the seals' own shear deflection ``z``: ``z' = v - sigma_0 |v| z / g(v)``,
    ``F = sigma_0 z + sigma_1 z' + sigma_2 v`` with ``sigma_0 = 2 k_s``, the Stribeck curve
    ``g(v) = F_C + (F_S - F_C) exp(-(v / v_S)^2)``, ``F_S = 2 F_fs`` (Armstrong-Helouvry, Dupont,
    Canudas de Wit, Automatica 30(7), 1994), a viscous film ``sigma_2`` and the seal's internal
    damping as LuGre's micro-damping ``sigma_1 = 2 zeta_1 sqrt(sigma_0 M_p)`` (not eq. 6's 5 Hz
    equivalent ``eta_s sigma_0 / w_e``, which with a Stribeck drop would make the law feed the
    piston's and caliper's kHz modes). Because ``c_eh`` also lumped the structure's own damping,
    the caliper and the load cells keep a structural damping ratio ``zeta`` (``2 zeta sqrt(k M)``
    on ``k_c`` and ``k_k``).
    Source: seed eqs. 2-6; LuGre (1995).

    ``strength`` is the share of the seal force carried by this law (and of the structural damping
    added); the rest stays the LTI spring and damper. At 1 the seals are purely frictional.
    """

    strength: float = 1.0
    coulomb_ratio: float = 0.8
    stribeck_velocity: float = 1.0e-3
    microdamping_ratio: float = 0.5
    viscous_friction: float = 500.0
    structural_damping_ratio: float = 0.1

    entry = catalogue.entry("seal_stick_slip")
    parameters = (
        STRENGTH,
        Parameter("coulomb_ratio", "-", 0.3, 1.0, "kinetic over static threshold F_C / F_S"),
        Parameter("stribeck_velocity", "m/s", 1.0e-5, 0.1, "v_S of the Stribeck curve"),
        Parameter("microdamping_ratio", "-", 0.0, 2.0, "zeta_1 of sigma_1"),
        Parameter("viscous_friction", "N s/m", 0.0, 1.0e4, "sigma_2, lubricant film, both seals"),
        Parameter("structural_damping_ratio", "-", 0.0, 0.3, "zeta of caliper and load cells"),
    )
    diagnosis_model = (
        "an ideal Jenkins element per seal: spring k_s in series with a rate-independent "
        "Coulomb slider F_fs; the simulator's law is smooth, rate dependent (Stribeck drop to "
        "F_C, viscous sigma_2, microdamping sigma_1) and creeps below the threshold"
    )

    def law(self, plant: LtiPlant) -> LuGreSeal:
        """The LuGre law of the plant's truth seals (both together).

        It carries ``strength`` of the seal force, with the structural damping it keeps.
        """
        seal = seal_properties(plant.rig)
        stiffness = 2.0 * seal.static_stiffness
        static = 2.0 * seal.friction_threshold
        params = plant.params
        caliper_damping, block_damping = structural_damping(
            params, 2.0 * self.strength * self.structural_damping_ratio
        )
        return LuGreSeal(
            bristle_stiffness=stiffness,
            static_force=static,
            coulomb_force=self.coulomb_ratio * static,
            stribeck_velocity=self.stribeck_velocity,
            microdamping=2.0
            * self.microdamping_ratio
            * math.sqrt(stiffness * plant.params.piston_mass),
            viscous_friction=self.viscous_friction,
            share=self.strength,
            caliper_damping=caliper_damping,
            block_damping=block_damping,
        )
