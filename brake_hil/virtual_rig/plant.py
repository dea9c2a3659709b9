"""The truth plant of the virtual rig: the LTI rig's coefficients plus the installed laws.

:func:`build_plant` derives the seed's coefficients (eqs. 2-20) of the *truth* rig at an
operating pressure, splits the line into its hard pipe, needle valve and hose (eqs. 12-14,
21c), and lets every active effect bind its truth law to them. The simulator
(:mod:`brake_hil.virtual_rig.simulator`) integrates eq. 21 with each law on the ports it
implements (:mod:`brake_hil.virtual_rig.laws`); with no law the equations are exactly the
seed's eq. 21. Neither knows an effect by name.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
import math

from brake_hil.physics.parameters import (
    DEFAULT_MEAN_PRESSURE,
    chamber_volumes,
    derive_parameters,
    line_inertance,
    line_resistance,
)
from brake_hil.physics.rig import Rig
from brake_hil.virtual_rig.effects.base import Effect, EffectError
from brake_hil.virtual_rig.laws import LtiPlant, TruthLaw, check_ports

__all__ = ["RIG_AIR_LAWS", "Plant", "base_plant", "build_plant"]

RIG_AIR_LAWS = ("linearised", "instantaneous")
"""How the rig's own air (``fluid.air_fraction``, eq. 18) is integrated: isothermal at the
operating pressure (``linearised``, eq. 18 as the LTI model has it) or isothermal at each
chamber's instantaneous pressure (``instantaneous``, as on a real rig: its compliance follows
the pressure within each cycle). Either is the rig itself, never an effect."""


@dataclass(frozen=True)
class Plant(LtiPlant):
    """The truth rig as the simulator integrates it (SI): the LTI plant and its laws."""

    laws: tuple[TruthLaw, ...] = ()  # the installed truth laws, in installation order
    effects: tuple[Effect, ...] = ()  # the active effects, in the order given
    rig_air: str = "linearised"  # the rig's own air law (RIG_AIR_LAWS)


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
    rig_air: str = "linearised",
) -> Plant:
    """The truth plant: :func:`base_plant` with every active effect installed.

    ``rig_air`` is the law of the rig's own air (:data:`RIG_AIR_LAWS`).

    Raises:
        EffectError: an effect is named twice, two effects' laws replace the same part
            of the rig, or an unknown air law.
    """
    if rig_air not in RIG_AIR_LAWS:
        raise EffectError(
            f"unknown law of the rig's own air {rig_air!r} (known: {', '.join(RIG_AIR_LAWS)})"
        )
    names = [effect.name for effect in effects]
    if twice := sorted({name for name in names if names.count(name) > 1}):
        raise EffectError(f"effect {twice[0]} is given more than once")
    plant = base_plant(rig, operating_pressure, master_damping_ratio)
    active = tuple(effect for effect in effects if effect.active)
    installed = [(effect.name, effect.install(plant)) for effect in active]
    laws = tuple(law for _, law in installed if law is not None)
    check_ports(laws, [name for name, law in installed if law is not None])
    return replace(plant, laws=laws, effects=active, rig_air=rig_air)
