"""hose_compliance: the hose and pipe between master cylinder and bore store fluid."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
import math

import numpy as np

from brake_hil.physics import catalogue
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, EffectError, Parameter
from brake_hil.virtual_rig.effects.registry import register_effect
from brake_hil.virtual_rig.laws import LineFlow, LinePorts, LtiPlant, Signal, State, TruthLaw


@dataclass(frozen=True)
class HoseLadder(TruthLaw):
    """The line as an RC ladder: pipe and valve, then ``N`` hose segments, bound to a rig.

    The host's line port, the node pressures its states.

    Node ``j`` (``0 .. N-1``) sits before hose segment ``j + 1`` (resistance ``R_t / N``); node 0
    is the valve outlet and carries the hard pipe's compliance. The bore end of the last segment
    carries ``bore_end_*``. Compliances are
    ``share * (volume * fluid compliance + wall compliance)``.
    """

    share: float  # s, -
    node_volumes: tuple[float, ...]  # m^3, fluid volume lumped at each node
    node_wall_compliances: tuple[float, ...]  # m^3/Pa, wall expansion lumped at each node
    bore_end_volume: float  # m^3
    bore_end_wall_compliance: float  # m^3/Pa

    @property
    def segment_count(self) -> int:
        """Number of hose segments ``N``."""
        return len(self.node_volumes)

    def node_compliance(self, node: int, fluid_compliance: Signal) -> Signal:
        """Compliance (m^3/Pa) of node ``node`` for a fluid compliance per volume (1/Pa)."""
        compliance: Signal = self.share * (
            self.node_volumes[node] * fluid_compliance + self.node_wall_compliances[node]
        )
        return compliance

    def bore_end_compliance(self, fluid_compliance: Signal) -> Signal:
        """Compliance (m^3/Pa) the hose adds to the bore chamber."""
        compliance: Signal = self.share * (
            self.bore_end_volume * fluid_compliance + self.bore_end_wall_compliance
        )
        return compliance

    def states(self) -> tuple[State, ...]:
        """The node pressures ``p_n0 .. p_n(N-1)`` (Pa)."""
        return tuple(State(f"p_n{node}", 1e6) for node in range(self.segment_count))

    def initial_state(self, equilibrium: Mapping[str, float]) -> tuple[float, ...]:
        """At rest every node is at the bore pressure."""
        return tuple(equilibrium["p_b"] for _ in range(self.segment_count))

    def line_flow(self, line: LinePorts, states: Sequence[Signal]) -> LineFlow:
        """Pipe and valve into node 0, then the hose segments node to node into the bore."""
        count = self.segment_count
        segment_resistance = line.hose_resistance / count
        nodes = states
        flow_rate = (line.master_pressure - nodes[0] - line.upstream_drop) / line.inertance
        inflow = line.flow
        rates: list[Signal] = []
        for node in range(count):
            downstream = nodes[node + 1] if node + 1 < count else line.bore_pressure
            outflow = (nodes[node] - downstream) / segment_resistance
            node_fluid = line.compliance_at(nodes[node])
            rates.append((inflow - outflow) / self.node_compliance(node, node_fluid))
            inflow = outflow
        bore_fluid = line.compliance_at(line.bore_pressure)
        return flow_rate, rates, inflow, self.bore_end_compliance(bore_fluid)


@register_effect
@dataclass(frozen=True)
class HoseCompliance(Effect):
    """Hose and pipe compliance between the master cylinder and the bore.

    The seed's flow equation (21c) moves fluid from the master cylinder to the bore through a rigid
    line, but the braided hose swells with pressure and the fluid in the line is compressible, so
    part of the flow is stored on the way and the bore pressure lags and is filtered more. The
    simulator splits the line into a transmission line of lumped segments: the hard pipe and needle
    valve (``R_r + R_v``, carrying the line's inertance ``I_r + I_t``) feed a node holding the
    pipe's compliance, then ``N`` hose segments of resistance ``R_t / N`` alternate with nodes of
    compliance ``V_t / (N beta) + l_t e_h / N`` (half of it at each end), ``e_h`` the hose's
    volumetric expansion per length and pressure (SAE J1401 rates brake hose by it).
    Source: seed eqs. 12-14, 18, 21c; Stecki and Davis, "Fluid transmission lines - distributed
    parameter models", Proc. IMechE A 200(4), 1986; SAE J1401.
    """

    strength: float = 1.0
    hose_expansion: float = 2.0e-13
    segments: int = 4

    entry = catalogue.entry("hose_compliance")
    parameters = (
        STRENGTH,
        Parameter("hose_expansion", "m^3/(Pa m)", 1.0e-14, 1.0e-12, "e_h, hose swell"),
        Parameter("segments", "-", 1, 16, "N, lumped hose segments"),
    )
    diagnosis_model = (
        "one lumped RC stage (a single extra compliance between the valve and the bore, "
        "its wall partly retarded); the simulator's line is a ladder of several elastic "
        "R-I-C segments"
    )

    def __post_init__(self) -> None:
        super().__post_init__()
        if int(self.segments) != self.segments:
            raise EffectError(f"effect {self.name}: segments = {self.segments!r} is not whole")

    def law(self, plant: LtiPlant) -> HoseLadder:
        """The ladder of the plant's truth line at this strength."""
        rig = plant.rig
        count = int(self.segments)
        pipe_volume = math.pi * rig.hard_pipe.diameter**2 / 4.0 * rig.hard_pipe.length
        pipe_wall = (
            pipe_volume
            * rig.hard_pipe.diameter
            / (rig.hard_pipe.wall * rig.hard_pipe.youngs_modulus)
        )
        hose_volume = math.pi * rig.hose.diameter**2 / 4.0 * rig.hose.length
        hose_wall = rig.hose.length * self.hose_expansion
        volumes = np.full(count, hose_volume / count)
        walls = np.full(count, hose_wall / count)
        volumes[0] = pipe_volume + 0.5 * hose_volume / count
        walls[0] = pipe_wall + 0.5 * hose_wall / count
        return HoseLadder(
            share=self.strength,
            node_volumes=tuple(float(v) for v in volumes),
            node_wall_compliances=tuple(float(w) for w in walls),
            bore_end_volume=0.5 * hose_volume / count,
            bore_end_wall_compliance=0.5 * hose_wall / count,
        )
