"""The truth plant of the virtual rig: the LTI rig's coefficients plus one slot per effect.

:func:`build_plant` derives the seed's coefficients (eqs. 2-20) of the *truth* rig at an
operating pressure, splits the line into its hard pipe, needle valve and hose (eqs. 12-14,
21c), and lets every active effect install its law into its slot. The simulator
(:mod:`brake_hil.virtual_rig.simulator`) integrates the equations the slots describe; with every
slot empty they are exactly the seed's eq. 21.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
import math
from typing import TYPE_CHECKING

from brake_hil.physics.parameters import (
    DEFAULT_MEAN_PRESSURE,
    ModelParameters,
    chamber_volumes,
    derive_parameters,
    line_inertance,
    line_resistance,
)
from brake_hil.physics.rig import Rig
from brake_hil.virtual_rig.effects.base import Effect, EffectError

if TYPE_CHECKING:
    from brake_hil.virtual_rig.effects.bore_friction import DahlBoreFriction
    from brake_hil.virtual_rig.effects.eccentric_load import LoadDependentShare
    from brake_hil.virtual_rig.effects.entrained_air import PolytropicAir
    from brake_hil.virtual_rig.effects.hose_compliance import HoseLadder
    from brake_hil.virtual_rig.effects.orifice_flow import OrificeValve
    from brake_hil.virtual_rig.effects.seal_stick_slip import LuGreSeal
    from brake_hil.virtual_rig.effects.sensor_delay import ChannelSkew
    from brake_hil.virtual_rig.effects.sensor_nonlinearity import QuadraticGain
    from brake_hil.virtual_rig.effects.thermal_drift import HeatingLaw


@dataclass(frozen=True)
class SealSlot:
    """How the piston seals push back (both seals together).

    With no friction law the seals are the seed's equivalent spring and damper
    (``k_eh``, ``c_eh``, eq. 21e-f). ``friction_share`` of the seal force is carried by the
    frictional law instead (seal_stick_slip); ``asymmetry`` makes the seal stiffer on one side
    of its relaxed position than on the other, and its slip threshold differ between apply and
    release (seal_groove_asymmetry).
    """

    friction: LuGreSeal | None = None
    friction_share: float = 0.0  # -, share of the seal force carried by the friction law
    asymmetry: float = 0.0  # -, a: apply side (1 - a), release side (1 + a)
    relaxation_time: float = 1.0  # s, creep of the seal's relaxed position
    asymmetry_width: float = 1.0e-6  # m, width of the smooth apply/release switch
    caliper_damping: float = 0.0  # N s/m, caliper to ground, kept when c_eh is replaced
    block_damping: float = 0.0  # N s/m, piston to block (load cells)


@dataclass(frozen=True)
class Plant:
    """The truth rig as the simulator integrates it (SI)."""

    rig: Rig  # the truth rig
    params: ModelParameters  # eq. 21 coefficients at ``operating_pressure``
    operating_pressure: float  # Pa, mean master-cylinder pressure the coefficients are at
    pipe_resistance: float  # R_r, Pa s/m^3 (eq. 13)
    valve_resistance: float  # R_v, Pa s/m^3 (linearised, eqs. 15-17)
    hose_resistance: float  # R_t, Pa s/m^3 (eq. 13)
    pipe_inertance: float  # I_r, Pa s^2/m^3 (eq. 14)
    hose_inertance: float  # I_t, Pa s^2/m^3 (eq. 14)
    master_volume: float  # V_i, m^3 (eq. 19)
    bore_volume: float  # V_b, m^3 (eq. 20)
    master_damping: float = 0.0  # c_i, N s/m, on the master piston (not in eq. 21a)
    seal: SealSlot = field(default_factory=SealSlot)
    valve: OrificeValve | None = None  # orifice_flow
    line: HoseLadder | None = None  # hose_compliance
    air: PolytropicAir | None = None  # entrained_air
    bore_friction: DahlBoreFriction | None = None  # bore_friction
    force_share: LoadDependentShare | None = None  # eccentric_load
    drift: HeatingLaw | None = None  # thermal_drift
    skews: tuple[ChannelSkew | QuadraticGain, ...] = ()  # sensor_delay, sensor_nonlinearity
    effects: tuple[Effect, ...] = ()  # the active effects, installed in this order


def base_plant(
    rig: Rig,
    operating_pressure: float = DEFAULT_MEAN_PRESSURE,
    master_damping_ratio: float = 0.0,
) -> Plant:
    """The LTI rig (no effect): eq. 21 coefficients of ``rig`` at ``operating_pressure`` (Pa).

    The line resistance and inertance of :func:`derive_parameters` (which honour the rig
    file's ``model:`` overrides) are split into the hard pipe's and the hose's laminar values
    (eqs. 13-14) and the needle valve's remainder. ``master_damping_ratio`` damps the master
    piston on the fluid's stiffness ``A_i^2 / C_i`` (its cup seals and the air cylinder's rod
    seal, which eq. 21a leaves out): ``c_i = 2 zeta sqrt(M_i A_i^2 / C_i)``.
    """
    params = derive_parameters(rig, operating_pressure)
    viscosity, density = rig.fluid.viscosity, rig.fluid.density
    pipe_resistance = line_resistance(rig.hard_pipe, viscosity)
    hose_resistance = line_resistance(rig.hose, viscosity)
    pipe_inertance = line_inertance(rig.hard_pipe, density)
    master_volume, bore_volume = chamber_volumes(rig)
    fluid_stiffness = params.master_area**2 / params.master_compliance  # N/m
    master_damping = 2.0 * master_damping_ratio * math.sqrt(fluid_stiffness * params.master_mass)
    return Plant(
        rig=rig,
        params=params,
        operating_pressure=operating_pressure,
        pipe_resistance=pipe_resistance,
        valve_resistance=params.line_resistance - pipe_resistance - hose_resistance,
        hose_resistance=hose_resistance,
        pipe_inertance=pipe_inertance,
        hose_inertance=params.line_inertance - pipe_inertance,
        master_volume=master_volume,
        bore_volume=bore_volume,
        master_damping=master_damping,
    )


def build_plant(
    rig: Rig,
    effects: Sequence[Effect] = (),
    operating_pressure: float = DEFAULT_MEAN_PRESSURE,
    master_damping_ratio: float = 0.0,
) -> Plant:
    """The truth plant: :func:`base_plant` with every active effect installed.

    Raises:
        EffectError: an effect is named twice.
    """
    names = [effect.name for effect in effects]
    if twice := sorted({name for name in names if names.count(name) > 1}):
        raise EffectError(f"effect {twice[0]} is given more than once")
    plant = base_plant(rig, operating_pressure, master_damping_ratio)
    active = tuple(effect for effect in effects if effect.active)
    for effect in active:
        plant = effect.install(plant)
    return replace(plant, effects=active)
