"""seal_stick_slip, family b: the seals as a Bouc-Wen hysteretic element."""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

from brake_hil.physics.parameters import seal_properties
from brake_hil.virtual_rig import _math as fm
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.family_b.base import FamilyBEffect, register_effect_b
from brake_hil.virtual_rig.laws import LtiPlant, SealPorts, Signal
from brake_hil.virtual_rig.mechanics import (
    ASYMMETRY_WIDTH_SHARE,
    FrictionalSeal,
    asymmetric_limit,
    smooth_speed,
    structural_damping,
)

__all__ = ["BoucWenSeal", "SealStickSlipB"]


@dataclass(frozen=True)
class BoucWenSeal(FrictionalSeal):
    """Bouc-Wen hysteresis of both seals together, bound to a rig (SI).

    The host's seal-force port (state ``z``, the seals' elastic shear deflection) and structural
    damping.
    """

    stiffness: float  # k = 2 k_s, N/m
    yield_force: float  # F_y, N
    sharpness: float  # n, -
    internal_damping: float  # c_r, N s/m, the rubber's loss in parallel
    film_damping: float  # c_f, N s/m, lubricant film (scales with viscosity)
    share: float = 1.0  # -, share of the seal force this law carries (the rest: k_eh, c_eh)
    caliper_damping: float = 0.0  # N s/m, caliper to ground, kept where c_eh is replaced
    block_damping: float = 0.0  # N s/m, piston to block (load cells)

    @property
    def yield_deflection(self) -> float:
        """``z_y = F_y / k`` (m)."""
        return self.yield_force / self.stiffness

    def deflection_rate(self, deflection: Signal, velocity: Signal, asymmetry: float) -> Signal:
        """``z' = v - |v| |r|^(n-1) r / 2 - v |r|^n / 2`` (m/s), ``r = z / z_y`` (Bouc-Wen).

        With ``beta = gamma = 1/2`` the seal unloads elastically (``z' = v`` when ``v r < 0``)
        and yields smoothly (``z' = v (1 - |r|^n)``) as ``|z|`` reaches ``z_y``; ``z_y`` is
        ``(1 - a)`` as large on the apply side (``z > 0``) and ``(1 + a)`` on release.
        """
        limit = self.yield_deflection
        if asymmetry:
            limit = asymmetric_limit(limit, asymmetry, deflection, ASYMMETRY_WIDTH_SHARE * limit)
        ratio = deflection / limit
        power = fm.absolute(ratio) ** (self.sharpness - 1.0)
        rate: Signal = velocity - 0.5 * power * (
            smooth_speed(velocity) * ratio + velocity * fm.absolute(ratio)
        )
        return rate

    def rest_limit(self) -> float:
        """At rest the seals are sheared below their yield (m)."""
        return 0.9 * self.yield_deflection

    def own_force(self, deflection: Signal, seal: SealPorts) -> tuple[Signal, Signal]:
        """``E k z + c_r v + mu c_f v`` (N), and ``z'`` (m/s).

        The seal modulus's drift factor ``E`` scales the stiffness and (through the squeeze
        force) the yield force alike, so the yield deflection stays.
        """
        velocity = seal.velocity
        rate = self.deflection_rate(deflection, velocity, seal.asymmetry)
        hysteretic = (
            self.stiffness * seal.modulus_factor * deflection
            + (self.internal_damping + self.film_damping * seal.viscosity_factor) * velocity
        )
        return hysteretic, rate


@register_effect_b
@dataclass(frozen=True)
class SealStickSlipB(FamilyBEffect, effect="seal_stick_slip"):
    """Seal stick-slip (family b): each seal a Bouc-Wen element, elastic then yielding smoothly.

    The seal shears with the piston at its shear-beam stiffness (seed eq. 3,
    ``k = 2 k_s`` for both seals) and yields as its force nears the friction threshold
    (seed eq. 2, ``F_y = 2 F_fs`` times ``yield_ratio``), by Bouc-Wen's rate-independent
    hysteresis ``z' = v - beta |v| |r|^(n-1) r - gamma v |r|^n`` with ``r = z k / F_y`` and
    ``beta = gamma = 1/2`` (Wen, "Method for random vibration of hysteretic systems", J. Eng.
    Mech. Div. ASCE 102(2), 1976; Ismail, Ikhouane, Rodellar, "The hysteresis Bouc-Wen model, a
    survey", Arch. Comput. Methods Eng. 16, 2009): unloading is elastic, loading rounds off into
    slip over a range set by the sharpness ``n`` (a Jenkins element at ``n -> infinity``). The
    seal force is ``k z`` plus the rubber's internal damping ``c_r = 2 zeta_r sqrt(k M_p)`` and a
    viscous film ``c_f`` (scaled with the fluid's viscosity) in parallel; where ``c_eh`` is
    removed, the caliper and load cells keep a structural damping ratio ``zeta`` as in family a.
    Unlike family a's LuGre law there is no Stribeck drop, no creep below the threshold and no
    rate dependence of the threshold: the loop's shape, not its rate, differs from a Jenkins
    element. Source: seed eqs. 2-3; Wen (1976).

    ``strength`` is the share of the seal force carried by this law (and of the structural
    damping added); the rest stays the LTI spring and damper.
    """

    strength: float = 1.0
    sharpness: float = 2.0
    yield_ratio: float = 1.0
    internal_damping_ratio: float = 0.5
    film_damping: float = 300.0
    structural_damping_ratio: float = 0.1

    parameters = (
        STRENGTH,
        Parameter("sharpness", "-", 1.0, 10.0, "n of Bouc-Wen: the yield's roundness"),
        Parameter("yield_ratio", "-", 0.5, 1.5, "F_y / (2 F_fs)"),
        Parameter("internal_damping_ratio", "-", 0.0, 2.0, "zeta_r of the rubber's loss"),
        Parameter("film_damping", "N s/m", 0.0, 1.0e4, "c_f, lubricant film, both seals"),
        Parameter("structural_damping_ratio", "-", 0.0, 0.3, "zeta of caliper and load cells"),
    )
    diagnosis_model = (
        "an ideal Jenkins element per seal: spring k_s in series with a rate-independent "
        "Coulomb slider F_fs; the simulator's Bouc-Wen loop yields gradually (sharpness n) "
        "and has the rubber's viscous loss in parallel"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> Effect:
        """Sharpness 1.5-4, yield 0.8-1.2 of ``2 F_fs``, internal damping ratio 0.3-0.8."""
        return cls(
            strength=strength,
            sharpness=float(np.round(rng.uniform(1.5, 4.0), 3)),
            yield_ratio=float(np.round(rng.uniform(0.8, 1.2), 3)),
            internal_damping_ratio=float(np.round(rng.uniform(0.3, 0.8), 3)),
        )

    def law(self, plant: LtiPlant) -> BoucWenSeal:
        """The Bouc-Wen law of the plant's truth seals (both together) at this strength."""
        seal = seal_properties(plant.rig)
        stiffness = 2.0 * seal.static_stiffness
        params = plant.params
        caliper_damping, block_damping = structural_damping(
            params, 2.0 * self.strength * self.structural_damping_ratio
        )
        return BoucWenSeal(
            stiffness=stiffness,
            yield_force=self.yield_ratio * 2.0 * seal.friction_threshold,
            sharpness=self.sharpness,
            internal_damping=2.0
            * self.internal_damping_ratio
            * math.sqrt(stiffness * params.piston_mass),
            film_damping=self.film_damping,
            share=self.strength,
            caliper_damping=caliper_damping,
            block_damping=block_damping,
        )
