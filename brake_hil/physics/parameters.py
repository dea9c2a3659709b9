"""Derived parameters of the seed's model (Liette et al. 2012, eqs. 2-20) from a Rig.

Conventions this project chose where the printed equations are ambiguous (physics.md):

* ``k_eh`` (eq. 4): the effective hydraulic stiffness of both seals together. The default
  (no recording, no ``model.k_eh``) is the seed's one-washer operating point
  ``k_eh* = 0.5 k_eh / k_s = 0.29``; characterisation measures it from a recording.
* ``c_eh``: default from the seed's loss factor ``eta_eh = c_eh w_e / k_eh = 0.93`` (eq. 11).
* The needle valve enters as the linearised resistance of the rig file (eqs. 15-17 give
  the conversion from a volume coefficient, :func:`valve_resistance`).
* The air modulus is isothermal, ``beta_a = mean p_i`` (eq. 18), so the compliances depend
  on the operating point: derive them at the mean master-cylinder pressure of the segment.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
import math
from typing import Final

from brake_hil.physics.rig import Line, Rig

SEED_K_EH_STAR = 0.29
"""Normalised effective seal stiffness ``0.5 k_eh / k_s`` at the seed's one-washer point."""
SEED_ETA_EH = 0.93
"""Effective hydraulic loss factor ``c_eh w_e / k_eh`` at the seed's one-washer point."""
DEFAULT_MEAN_PRESSURE = 0.9e6
"""Operating mean master-cylinder pressure (Pa) when no recording gives one."""
LAMINAR_REYNOLDS_LIMIT = 2000.0


@dataclass(frozen=True)
class SealProperties:
    """Per-seal quantities, seed eqs. 2-3."""

    normal_force: float  # N_s, N (eq. 2)
    friction_threshold: float  # F_fs, N (eq. 2)
    shear_modulus: float  # G_s, Pa
    static_stiffness: float  # k_s, N/m (eq. 3)
    slip_threshold: float  # c_s = F_fs / k_s, m


@dataclass(frozen=True)
class ModelParameters:
    """Coefficients of the LTI model, seed eq. 21 (SI)."""

    piston_area: float  # A_ep, m^2 (all pistons)
    bore_area: float  # A_eb, m^2
    piston_mass: float  # M_p, kg
    caliper_mass: float  # M_c, kg
    block_stiffness: float  # k_k, N/m
    caliper_stiffness: float  # k_c, N/m
    effective_hydraulic_stiffness: float  # k_eh, N/m
    effective_hydraulic_damping: float  # c_eh, N s/m
    line_resistance: float  # R_r + R_v + R_t, Pa s/m^3 (eq. 21c)
    line_inertance: float  # I_r + I_t, Pa s^2/m^3 (eq. 21c)
    bore_compliance: float  # C_b, m^3/Pa (eq. 20)
    master_compliance: float  # C_i, m^3/Pa (eq. 19)
    master_area: float  # A_i, m^2 (eq. 21a-b)
    air_piston_area: float  # A_a, m^2 (eq. 21a)
    master_mass: float  # M_i, kg
    master_spring_stiffness: float  # k_i, N/m

    def with_changes(self, **changes: float) -> ModelParameters:
        """Copy with some coefficients replaced (calibration, overrides)."""
        return replace(self, **changes)


def seal_properties(rig: Rig) -> SealProperties:
    """Seal normal force, friction threshold and static stiffness, seed eqs. 2-3."""
    seal = rig.seal
    contact_area = math.pi * rig.piston_diameter * seal.width  # pi d_p w_s, m^2
    normal_force = seal.youngs_modulus * seal.squeeze * contact_area
    shear_modulus = seal.youngs_modulus / (2.0 * (1.0 + seal.poisson_ratio))
    static_stiffness = shear_modulus * contact_area / seal.shear_length
    friction_threshold = seal.friction_coefficient * normal_force
    return SealProperties(
        normal_force=normal_force,
        friction_threshold=friction_threshold,
        shear_modulus=shear_modulus,
        static_stiffness=static_stiffness,
        slip_threshold=friction_threshold / static_stiffness,
    )


def piston_area(rig: Rig) -> float:
    """Total piston area A_ep (m^2)."""
    return rig.piston_count * math.pi * rig.piston_diameter**2 / 4.0


def excitation_angular_frequency(rig: Rig) -> float:
    """w_e = 2 pi f_e (rad/s)."""
    return 2.0 * math.pi * rig.excitation_hz


def line_resistance(line: Line, viscosity: float) -> float:
    """Laminar (Hagen-Poiseuille) resistance ``128 mu l / (pi d^4)`` (Pa s/m^3), eq. 13."""
    return 128.0 * viscosity * line.length / (math.pi * line.diameter**4)


def line_inertance(line: Line, density: float) -> float:
    """Fluid inertance with the laminar profile ``(4/3) rho l / A`` (Pa s^2/m^3), eq. 14."""
    return (4.0 / 3.0) * density * line.length / (math.pi * line.diameter**2 / 4.0)


def reynolds_number(flow: float, line: Line, density: float, viscosity: float) -> float:
    """``Re = |Q| rho d / (mu A)`` for volume flow ``flow`` (m^3/s), eq. 12."""
    area = math.pi * line.diameter**2 / 4.0
    return abs(flow) * density * line.diameter / (viscosity * area)


def valve_resistance(
    volume_coefficient: float, specific_weight: float, pressure_drop: float
) -> float:
    """Linearised needle-valve resistance ``2 sqrt(gamma dp_o) / B_V`` (Pa s/m^3), eq. 16.

    ``volume_coefficient`` B_V in m^3/s per sqrt(Pa/(N/m^3)); ``specific_weight`` gamma =
    rho g (N/m^3); ``pressure_drop`` dp_o the operating drop (Pa).
    """
    return 2.0 * math.sqrt(specific_weight * pressure_drop) / volume_coefficient


def restricted_volume_coefficient(
    open_coefficient: float, needle_diameter: float, valve_diameter: float
) -> float:
    """Volume coefficient of a partly closed needle valve, ``B_V ~ (1 - d_dv/d_v)^2``, eq. 17."""
    return open_coefficient * (1.0 - needle_diameter / valve_diameter) ** 2


def effective_bulk_modulus(rig: Rig, mean_pressure: float) -> float:
    """Effective bulk modulus beta_e (Pa) of fluid, entrained air and line walls, eq. 18.

    The air is isothermal: its modulus equals the mean gauge pressure ``mean_pressure``
    (floored at 1 kPa so a zero-pressure start stays finite).
    """
    fluid = rig.fluid
    air_modulus = max(mean_pressure, 1.0e3)
    inverse = (1.0 - fluid.air_fraction) / fluid.bulk_modulus + fluid.air_fraction / air_modulus
    for line in (rig.hard_pipe, rig.hose):
        inverse += line.diameter / (line.wall * line.youngs_modulus)
    return 1.0 / inverse


def chamber_volumes(rig: Rig) -> tuple[float, float]:
    """Master-cylinder and bore-chamber fluid volumes ``(V_i, V_b)`` (m^3), eqs. 19-20."""
    area_ep = piston_area(rig)
    master = rig.master_cylinder
    master_area = math.pi * master.diameter**2 / 4.0
    washer_volume = area_ep * (rig.washers - 1) * rig.washer_thickness
    master_volume = max(
        master_area * master.length - washer_volume, 0.05 * master_area * master.length
    )
    bore_volume = rig.bore_area_ratio * area_ep * rig.bore_length + washer_volume
    return master_volume, bore_volume


def derive_parameters(rig: Rig, mean_pressure: float = DEFAULT_MEAN_PRESSURE) -> ModelParameters:
    """All LTI-model coefficients from a rig at a mean master-cylinder pressure (Pa).

    Values in the rig's ``model:`` mapping replace the derived ones (docs/interface.md).
    """
    seal = seal_properties(rig)
    area_ep = piston_area(rig)
    beta_e = effective_bulk_modulus(rig, mean_pressure)
    master_volume, bore_volume = chamber_volumes(rig)
    k_eh = 2.0 * SEED_K_EH_STAR * seal.static_stiffness
    c_eh = SEED_ETA_EH * k_eh / excitation_angular_frequency(rig)
    fluid = rig.fluid
    resistance = (
        line_resistance(rig.hard_pipe, fluid.viscosity)
        + rig.needle_valve_resistance
        + line_resistance(rig.hose, fluid.viscosity)
    )
    inertance = line_inertance(rig.hard_pipe, fluid.density) + line_inertance(
        rig.hose, fluid.density
    )
    master = rig.master_cylinder
    params = ModelParameters(
        piston_area=area_ep,
        bore_area=rig.bore_area_ratio * area_ep,
        piston_mass=rig.piston_mass,
        caliper_mass=rig.caliper_mass,
        block_stiffness=rig.block_stiffness,
        caliper_stiffness=rig.caliper_stiffness,
        effective_hydraulic_stiffness=k_eh,
        effective_hydraulic_damping=c_eh,
        line_resistance=resistance,
        line_inertance=inertance,
        bore_compliance=bore_volume / beta_e,
        master_compliance=master_volume / beta_e,
        master_area=math.pi * master.diameter**2 / 4.0,
        air_piston_area=math.pi * master.air_piston_diameter**2 / 4.0,
        master_mass=master.mass,
        master_spring_stiffness=master.spring_stiffness,
    )
    return apply_overrides(params, rig)


MODEL_OVERRIDES: Final[Mapping[str, str]] = {
    "k_eh": "effective_hydraulic_stiffness",
    "c_eh": "effective_hydraulic_damping",
    "C_b": "bore_compliance",
    "C_i": "master_compliance",
    "R_line": "line_resistance",
    "I_line": "line_inertance",
    "k_c": "caliper_stiffness",
    "k_k": "block_stiffness",
}
"""The keys of a rig file's ``model:`` mapping that replace a model parameter outright, and
the :class:`ModelParameters` field each sets (``R_v`` and ``A_eb_over_A_ep`` are combined
with derived values: :func:`apply_overrides`)."""


def apply_overrides(params: ModelParameters, rig: Rig) -> ModelParameters:
    """Apply the rig file's ``model:`` mapping (``k_eh``, ``c_eh``, ``C_b``, ``R_v``, ...)."""
    o = rig.model_overrides
    changes = {field: o[key] for key, field in MODEL_OVERRIDES.items() if key in o}
    if "R_v" in o and "R_line" not in o:  # the needle valve's share of the line resistance
        changes["line_resistance"] = (
            params.line_resistance - rig.needle_valve_resistance + o["R_v"]
        )
    if "A_eb_over_A_ep" in o:
        changes["bore_area"] = o["A_eb_over_A_ep"] * params.piston_area
    return params.with_changes(**changes) if changes else params
