"""hose_compliance, family b: one line node whose hose wall creeps (viscoelastic)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
import math

import numpy as np

from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.family_b.base import FamilyBEffect, register_effect_b
from brake_hil.virtual_rig.laws import LineFlow, LinePorts, LtiPlant, Signal, State, TruthLaw

__all__ = ["CreepingHose", "HoseComplianceB"]


@dataclass(frozen=True)
class CreepingHose(TruthLaw):
    """The line as a T-section whose node's wall creeps (Kelvin-Voigt), bound to a rig (SI).

    The host's line port; states the node pressure ``p_n`` and the pressure ``p_r`` the wall's
    retarded expansion is in equilibrium with.
    """

    share: float  # s, -
    node_volume: float  # m^3, the line's fluid, lumped at the hose's middle
    instant_wall_compliance: float  # C_w, m^3/Pa, pipe and hose walls, elastic
    creep_wall_compliance: float  # C_d, m^3/Pa, the hose wall's retarded expansion
    creep_time: float  # tau_w, s, the wall's retardation time

    def states(self) -> tuple[State, ...]:
        """Node pressure ``p_n`` and the wall's retarded pressure ``p_r`` (Pa)."""
        return (State("p_n", 1e6), State("p_r", 1e6))

    def initial_state(self, equilibrium: Mapping[str, float]) -> tuple[float, ...]:
        """At rest the node and the wall are at the bore pressure."""
        return (equilibrium["p_b"], equilibrium["p_b"])

    def line_flow(self, line: LinePorts, states: Sequence[Signal]) -> LineFlow:
        """Pipe, valve and half the hose into the node, the other half on into the bore.

        ``p_r' = (p_n - p_r) / tau_w``; the node stores ``C p_n' + C_d p_r'``.
        """
        node, retarded = states
        half = 0.5 * line.hose_resistance
        flow_rate = (
            line.master_pressure - node - line.upstream_drop - half * line.flow
        ) / line.inertance
        outflow = (node - line.bore_pressure) / half
        fluid = line.compliance_at(node)
        compliance = self.share * (self.node_volume * fluid + self.instant_wall_compliance)
        creep_rate = (node - retarded) / self.creep_time
        creep_flow = self.share * self.creep_wall_compliance * creep_rate
        node_rate = (line.flow - outflow - creep_flow) / compliance
        return flow_rate, [node_rate, creep_rate], outflow, 0.0


@register_effect_b
@dataclass(frozen=True)
class HoseComplianceB(FamilyBEffect, effect="hose_compliance"):
    """Hose and pipe compliance (family b): one line node whose hose wall creeps.

    Eq. 21c moves fluid through a rigid line, but the fluid in the line is compressible and
    the braided rubber hose swells, partly at once and partly with a delay (its rubber is
    viscoelastic), so part of the flow is stored on the way and the bore pressure lags. The
    simulator lumps the line's fluid and walls in one node at the middle of the hose (a
    T-section: hard pipe, valve and half the hose, ``R_r + R_v + R_t / 2`` with the line's
    inertance, into the node, then ``R_t / 2`` into the bore); the node stores
    ``V / beta + C_w`` at once and a retarded wall volume ``C_d p_r`` with
    ``p_r' = (p_n - p_r) / tau_w`` (a Kelvin-Voigt creep element, as for polymer pipes: Covas,
    Stoianov, Ramos, Graham, Maksimovic, "The dynamic effect of pipe-wall viscoelasticity in
    hydraulic transients", J. Hydraulic Research 42(5), 2004), ``C_w = l_t e_h`` plus the
    steel pipe's swell and ``C_d = creep_ratio C_w`` (SAE J1401 rates brake hose by its
    volumetric expansion). Unlike family a (a ladder of several elastic RC segments) the
    storage is in one node and its compliance falls with frequency.
    Source: seed eqs. 12-14, 18, 21c; Covas et al. (2004); SAE J1401.
    """

    strength: float = 1.0
    hose_expansion: float = 1.5e-13
    creep_ratio: float = 1.0
    creep_time: float = 0.02

    parameters = (
        STRENGTH,
        Parameter("hose_expansion", "m^3/(Pa m)", 1.0e-14, 1.0e-12, "e_h, instant hose swell"),
        Parameter("creep_ratio", "-", 0.0, 5.0, "C_d / C_w, the wall's retarded share"),
        Parameter("creep_time", "s", 1.0e-3, 1.0, "tau_w, the wall's retardation time"),
    )
    diagnosis_model = (
        "one lumped RC stage between the valve and the bore whose wall creeps too "
        "(Kelvin-Voigt, the same form as this law); the simulator's node sits mid-hose and "
        "takes the line's fluid and the steel pipe's swell"
    )

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> Effect:
        """Hose swell 1-2e-13 m^3/(Pa m), creep ratio 0.5-1.5, retardation 10-50 ms."""
        return cls(
            strength=strength,
            hose_expansion=float(np.round(rng.uniform(1.0e-13, 2.0e-13), 16)),
            creep_ratio=float(np.round(rng.uniform(0.5, 1.5), 3)),
            creep_time=float(np.round(rng.uniform(0.01, 0.05), 4)),
        )

    def law(self, plant: LtiPlant) -> CreepingHose:
        """The T-section of the plant's truth line at this strength."""
        rig = plant.rig
        pipe, hose = rig.hard_pipe, rig.hose
        pipe_volume = math.pi * pipe.diameter**2 / 4.0 * pipe.length
        pipe_wall = pipe_volume * pipe.diameter / (pipe.wall * pipe.youngs_modulus)
        hose_volume = math.pi * hose.diameter**2 / 4.0 * hose.length
        hose_wall = hose.length * self.hose_expansion
        return CreepingHose(
            share=self.strength,
            node_volume=pipe_volume + hose_volume,
            instant_wall_compliance=pipe_wall + hose_wall,
            creep_wall_compliance=self.creep_ratio * hose_wall,
            creep_time=self.creep_time,
        )
