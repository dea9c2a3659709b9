"""The virtual rig: a higher-fidelity simulator of the seed's rig, ROS-free (numpy/scipy).

It integrates the truth rig with the physics the LTI model leaves out (:mod:`.effects`),
measures it like the rig's DAQ, and writes recordings and labelled benchmark cases.
"""

from __future__ import annotations

from brake_hil.errors import SimulationError
from brake_hil.virtual_rig.effects import EFFECTS, Effect, EffectError, make_effect, parse_effect
from brake_hil.virtual_rig.excitation import (
    Excitation,
    frequency_sweep,
    pressure_ramp,
    seed_pulsing,
    solenoid_pulsing,
)
from brake_hil.virtual_rig.plant import Plant, base_plant, build_plant
from brake_hil.virtual_rig.simulator import (
    RigRun,
    SolverStats,
    acquire,
    simulate_rig,
)

__all__ = [
    "EFFECTS",
    "Effect",
    "EffectError",
    "Excitation",
    "Plant",
    "RigRun",
    "SimulationError",
    "SolverStats",
    "acquire",
    "base_plant",
    "build_plant",
    "frequency_sweep",
    "make_effect",
    "parse_effect",
    "pressure_ramp",
    "seed_pulsing",
    "simulate_rig",
    "solenoid_pulsing",
]
