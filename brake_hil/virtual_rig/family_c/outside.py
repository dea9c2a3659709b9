"""Family c's own physics outside the library: what its ``unexplained`` cases are made of.

Three laws no candidate of the library models, each with its own entry (kept out of the
global catalogue): play in the caliper's displacement probe, a seal lip that leaks above a
cracking pressure, and a load cell that saturates.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from brake_hil.physics.catalogue import EffectEntry, Quantity
from brake_hil.types import FloatArray
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.family_c._common import positive_part
from brake_hil.virtual_rig.family_c.base import register_outside_c
from brake_hil.virtual_rig.laws import LineFlow, LinePorts, LtiPlant, Signal, TruthLaw

__all__ = ["CaliperProbePlayC", "LeakingSealC", "SaturatingLoadCellC"]


def play(values: FloatArray, width: float) -> FloatArray:
    """The play (backlash) operator of total ``width``: the output moves only when pushed."""
    out = np.empty_like(values)
    position = float(values[0])
    half = 0.5 * width
    for index, value in enumerate(values.tolist()):
        if value > position + half:
            position = value - half
        elif value < position - half:
            position = value + half
        out[index] = position
    return out


@dataclass(frozen=True)
class _ProbePlay(TruthLaw):
    width: float  # m

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        del time
        return play(values, self.width) if channel == "x_c" else values


@register_outside_c
@dataclass(frozen=True)
class CaliperProbePlayC(Effect):
    """Play in the caliper's displacement probe: its tip rides in a loose mount.

    The probe's holder has a clearance ``b`` along the measuring axis, so the reading follows
    the caliper only once the clearance is taken up in each direction (a backlash: flat
    stretches at every turning point of ``x_c``, its peak-to-peak short by ``b``).
    """

    entry: ClassVar[EffectEntry] = EffectEntry(
        name="caliper_probe_play",
        title="play in the caliper displacement probe's mount",
        physics="The x_c reading follows the caliper through a backlash of width b.",
        source="measurement chain (not in the paper)",
        signature="x_c flat at each turning point, its peak-to-peak short by b; p_b, F_k right",
        channels=("x_c",),
        quantities=(Quantity("b", "m", "total play of the probe's mount"),),
    )
    width: float = 3.0e-6

    parameters: ClassVar[tuple[Parameter, ...]] = (
        STRENGTH,
        Parameter("width", "m", 1e-7, 2e-5, "the mount's total play b at full strength"),
    )
    diagnosis_model: ClassVar[str] = "none in the library (unexplained)"

    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""
        del plant
        return _ProbePlay(self.strength * self.width)


@dataclass(frozen=True)
class _LeakingLip(TruthLaw):
    conductance: float  # m^3/(s Pa), the open lip's leakage conductance
    cracking: float  # Pa, the bore pressure at which the lip lifts
    width: float  # Pa, rounding of the opening

    def line_flow(self, line: LinePorts, states: Sequence[Signal]) -> LineFlow:
        del states
        leak = self.conductance * positive_part(line.bore_pressure - self.cracking, self.width)
        rate = line.lumped_rate(line.hose_resistance * line.flow)
        return rate, [], line.flow - leak, 0.0


@register_outside_c
@dataclass(frozen=True)
class LeakingSealC(Effect):
    """A seal lip that leaks past the piston once the bore pressure lifts it.

    Above the cracking pressure ``p_c`` fluid escapes the bore chamber at
    ``G (p_b - p_c)`` (a laminar leak path that opens): the bore loses fluid in the high
    half of each cycle, its pressure falls short there and the line carries a mean flow.
    """

    entry: ClassVar[EffectEntry] = EffectEntry(
        name="leaking_seal",
        title="a piston-seal lip that leaks above a cracking pressure",
        physics="Fluid leaves the bore at G (p_b - p_c) when p_b exceeds p_c.",
        source="seal failure (not in the paper)",
        signature="p_b short of the prediction in its high half, more at high pressure",
        channels=("p_b", "F_k", "x_c"),
        quantities=(
            Quantity("G", "m^3/(s Pa)", "leak conductance of the open lip"),
            Quantity("p_c", "Pa", "cracking pressure"),
        ),
    )
    cracking: float = 1.2e6

    parameters: ClassVar[tuple[Parameter, ...]] = (
        STRENGTH,
        Parameter("cracking", "Pa", 2e5, 3e6, "the bore pressure p_c that lifts the lip"),
    )
    diagnosis_model: ClassVar[str] = "none in the library (unexplained)"

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> LeakingSealC:
        """This law at ``strength``, its own parameters drawn from ``rng`` (a case's draw)."""
        return cls(strength=strength, cracking=float(np.round(rng.uniform(0.9e6, 1.5e6), -3)))

    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""
        # at full strength the open lip conducts a twentieth of what the line does
        line = plant.params.line_resistance
        return _LeakingLip(0.05 * self.strength / line, self.cracking, 2.0e4)


@dataclass(frozen=True)
class _Saturation(TruthLaw):
    knee: float  # N, where the cell's output bends

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        del time
        if channel != "F_k":
            return values
        return np.asarray(self.knee * np.tanh(values / self.knee), dtype=float)


@register_outside_c
@dataclass(frozen=True)
class SaturatingLoadCellC(Effect):
    """Load cells whose output saturates: their strain gauges' bridge bends over at high load.

    The reading is ``F_s tanh(F_k / F_s)``: linear at low load, compressed near the knee
    ``F_s`` (a cell overloaded once, or its amplifier near its rail).
    """

    entry: ClassVar[EffectEntry] = EffectEntry(
        name="saturating_load_cell",
        title="load cells whose output saturates toward a knee",
        physics="The F_k reading is F_s tanh(F_k / F_s).",
        source="measurement chain (not in the paper)",
        signature="F_k's amplitude short of the prediction, more at high load; p_b, x_c right",
        channels=("F_k",),
        quantities=(Quantity("F_s", "N", "the cells' saturation knee"),),
    )

    parameters: ClassVar[tuple[Parameter, ...]] = (STRENGTH,)
    diagnosis_model: ClassVar[str] = "none in the library (unexplained)"

    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""
        del plant
        # full strength: the knee at 2.5 times the 8.9 kN range, some % at the top
        return _Saturation(2.5 * 8.9e3 / self.strength**0.5)
