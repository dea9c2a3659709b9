"""Five more kinds of physics outside the diagnosis's library, to test ``unexplained``.

Each is a truth law of the virtual rig (an :class:`~brake_hil.virtual_rig.effects.base.Effect`
acting through the host's ports, :mod:`brake_hil.virtual_rig.laws`) with its own entry in
:data:`brake_hil.physics.catalogue.OUT_OF_LIBRARY` and no candidate in the diagnosis: a case
with one is labelled ``unexplained``. None is what a library candidate models (stick-slip and
groove asymmetry of the seal, entrained air, orifice flow, hose compliance, bore friction,
eccentric load, thermal drift, a channel delay), and no two are alike:

==========================  ================  ==============================================
effect                      port              the physics
==========================  ================  ==============================================
``fluid_leak``              line              fluid lost from the bore past a seal lip
``check_valve_bypass``      valve             the needle valve bypassed by a check on release
``force_sensor_hysteresis`` acquisition F_k   a load cell's rate-independent hysteresis
``pressure_tap_resonance``  acquisition p_b   the p_b transducer behind a resonant tapping line
``pressure_zero_shift``     acquisition p_b   the p_b transducer's zero shifted by its peak
==========================  ================  ==============================================

Each law is marked where it is defined (no list names them; their laws on the host's ports
are in :mod:`~brake_hil.virtual_rig.family_b._outside_laws`). Importing the module registers
the five (catalogue entry, then truth law), in that order, with :func:`register_outside`,
which is idempotent: a second import, a reload or a worker process that imports it again
registers nothing twice. :func:`unregister_outside` takes them out again (a test that must
see the built-in ``OUT_OF_LIBRARY`` only).
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import TypeVar

import numpy as np

from brake_hil.errors import EffectError
from brake_hil.physics import catalogue
from brake_hil.physics.catalogue import EffectEntry, Quantity
from brake_hil.physics.measurement import SENSORS
from brake_hil.virtual_rig.effects import (
    OUT_OF_LIBRARY,
    register_effect,
    unregister_effect,
)
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, Parameter
from brake_hil.virtual_rig.family_b._outside_laws import (
    BypassedValve,
    LeakyLine,
    PeakZeroShift,
    PlayHysteresis,
    TapResonance,
)
from brake_hil.virtual_rig.laws import LtiPlant

__all__ = [
    "OUTSIDE_LAWS",
    "OUTSIDE_NAMES",
    "CheckValveBypass",
    "FluidLeak",
    "ForceSensorHysteresis",
    "PressureTapResonance",
    "PressureZeroShift",
    "register_outside",
    "unregister_outside",
]

_FORCE_FULL_SCALE = max(abs(SENSORS["F_k"].low), abs(SENSORS["F_k"].high))  # N, 8.9 kN


_DEFINED: list[type[Effect]] = []
"""The truth laws of this module, in the order they are defined."""

_Law = TypeVar("_Law", bound=type[Effect])


def _outside_law(cls: _Law) -> _Law:
    """Note ``cls`` as one of this module's laws (a class decorator; :func:`register_outside`)."""
    _DEFINED.append(cls)
    return cls


def _shared(item: EffectEntry) -> EffectEntry:
    """The catalogue's own entry when an equal one is registered already (a reload), else ``item``.

    So that ``cls.entry is catalogue.entry(name)`` holds however often the module runs.
    """
    held = catalogue.OUT_OF_LIBRARY.get(item.name)
    return held if held == item else item


# --------------------------------------------------------------------------- fluid_leak

FLUID_LEAK = _shared(
    EffectEntry(
        name="fluid_leak",
        title="fluid lost from the bore chamber past a seal lip or a fitting",
        physics=(
            "A worn piston-seal lip, a weeping bleed screw or a loose fitting lets fluid out of "
            "the bore chamber through a thin gap, a laminar flow proportional to the bore "
            "pressure (the gap opening a little with it); the master cylinder makes the loss "
            "up through the line, so p_b settles below p_i by the line's drop."
        ),
        source="Merritt 1967, Hydraulic Control Systems, laminar leakage through an annulus",
        signature=(
            "p_b's mean below p_i's by a share growing with the pressure, in every segment; "
            "F_k and x_c follow p_b; p_b's amplitude slightly low and leading"
        ),
        channels=("p_b", "F_k", "x_c"),
        quantities=(
            Quantity("G_L", "m^3/(Pa s)", "leak conductance at gauge zero"),
            Quantity("p_d", "Pa", "pressure that doubles the leak gap"),
        ),
    )
)


@_outside_law
@dataclass(frozen=True)
class FluidLeak(Effect):
    """Fluid leak: the bore chamber loses fluid through a thin gap, a flow ~ its pressure.

    A worn or nicked piston-seal lip, a weeping bleed screw or a loose banjo fitting opens a
    thin annular gap from the bore chamber to atmosphere; the flow through it is laminar,
    ``Q_L = G_L p_b (1 + p_b / p_d)^3`` with ``G_L = pi d h_0^3 / (12 mu l)`` (the gap ``h``
    opening linearly with the pressure, the lip lifting) and inversely proportional to the
    fluid viscosity. The line feeds the loss from the master cylinder, so in steady pulsing
    the bore pressure settles below the master-cylinder pressure by ``(R_r + R_v + R_t) Q_L``
    and the bore's fluid balance gains a resistive branch in parallel with its compliance.
    Source: Merritt, Hydraulic Control Systems (1967), leakage flow through an annulus;
    SAE J1703 (brake fluid), whose viscosity sets the leak. No candidate of the diagnosis
    lets fluid out of the rig (orifice flow and hose compliance act in series with the line,
    and at rest every one of them has ``p_b = p_i``): a case with it is ``unexplained``.
    """

    strength: float = 1.0
    conductance: float = 5.0e-13
    dilation_pressure: float = 2.0e7

    entry = FLUID_LEAK
    parameters = (
        STRENGTH,
        Parameter("conductance", "m^3/(Pa s)", 0.0, 1.0e-11, "G_L at gauge zero, strength 1"),
        Parameter("dilation_pressure", "Pa", 1.0e6, 1.0e9, "p_d: the gap doubles at it"),
    )
    diagnosis_model = "none: outside the library (no candidate lets fluid out of the rig)"

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> FluidLeak:
        """A leak at ``strength`` whose gap dilation ``p_d`` is drawn log-uniform, 10-100 MPa."""
        dilation = float(np.round(10.0 ** rng.uniform(7.0, 8.0), -4))
        return cls(strength=strength, dilation_pressure=dilation)

    def law(self, plant: LtiPlant) -> LeakyLine:
        """The leaky line of ``plant`` at this strength."""
        return LeakyLine(
            conductance=self.strength * self.conductance,
            dilation_pressure=self.dilation_pressure,
            nominal_hose_resistance=plant.hose_resistance,
        )


# --------------------------------------------------------------------------- check_valve_bypass

CHECK_VALVE_BYPASS = _shared(
    EffectEntry(
        name="check_valve_bypass",
        title="the needle valve is bypassed by a check valve on release",
        physics=(
            "A flow-control valve with an integral check throttles the apply flow through the "
            "needle but lets the release flow back through the check once the drop exceeds its "
            "cracking pressure: the line's resistance differs between apply and release."
        ),
        source="Merritt 1967, Hydraulic Control Systems; ISO 1219-1 (one-way flow control)",
        signature=(
            "p_b rises more slowly than it falls (a lopsided wave, even harmonics that p_i "
            "lacks); p_b's mean below p_i's by a share of the drop; F_k and x_c follow p_b"
        ),
        channels=("p_b", "F_k", "x_c"),
        quantities=(
            Quantity("r_b", "-", "bypass conductance times the needle's resistance R_v"),
            Quantity("d", "-", "share of R_v the open check takes off on release"),
            Quantity("p_c", "Pa", "cracking pressure of the check"),
        ),
    )
)


@_outside_law
@dataclass(frozen=True)
class CheckValveBypass(Effect):
    """Check-valve bypass: the needle valve throttles the apply flow only.

    The rig's needle valve is a one-way flow-control valve: a spring-loaded ball check in
    parallel with the needle stays shut while fluid flows to the bore (the needle alone
    meters it, ``R_v``) and opens when the release flow's drop exceeds its cracking pressure
    ``p_c``, adding a conductance ``G_b = r_b / R_v`` (laminar, linearised as the needle's own
    resistance is). The line's resistance is then ``R_v`` on apply and ``R_v / (1 + r_b)`` on
    release, which the strength sets to ``R_v (1 - d strength)`` (``d`` = 0.7 by default),
    with a smooth corner at the cracking point: p_b rises more slowly than it falls and, the
    bore filling slower than it empties, its mean sits below p_i's. Source: Merritt,
    Hydraulic Control Systems (1967), check and flow-control valves; ISO 1219-1 (2012), the
    one-way flow-control valve. The library's valve law (orifice flow) is symmetric in the
    flow and the seal's asymmetry acts on the caliper, not on the line: a case with this is
    ``unexplained``.
    """

    strength: float = 1.0
    release_relief: float = 0.7
    cracking_pressure: float = 4.0e3

    entry = CHECK_VALVE_BYPASS
    parameters = (
        STRENGTH,
        Parameter("release_relief", "-", 0.0, 0.95, "d, share of R_v off on release at 1"),
        Parameter("cracking_pressure", "Pa", 0.0, 1.0e5, "p_c, the check's cracking pressure"),
    )
    diagnosis_model = "none: outside the library (no candidate's line differs by flow direction)"

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> CheckValveBypass:
        """A bypass at ``strength`` whose cracking pressure is drawn uniform, 1-10 kPa."""
        cracking = float(np.round(rng.uniform(1.0e3, 1.0e4), -1))
        return cls(strength=strength, cracking_pressure=cracking)

    def law(self, plant: LtiPlant) -> BypassedValve:
        """The bypassed valve at this strength (the needle's ``R_v`` comes from the host)."""
        del plant
        relief = self.strength * self.release_relief
        return BypassedValve(
            bypass_ratio=relief / (1.0 - relief),
            cracking_pressure=self.cracking_pressure,
            smoothing=500.0,
        )


# ------------------------------------------------------------------- force_sensor_hysteresis

FORCE_SENSOR_HYSTERESIS = _shared(
    EffectEntry(
        name="force_sensor_hysteresis",
        title="a load cell whose reading lags its load by a rate-independent hysteresis",
        physics=(
            "The load cells' flexures and their seating on the block rub and creep, so the "
            "reading on unloading differs from that on loading at the same force: a hysteresis "
            "loop that does not depend on the rate, only on the path of the load."
        ),
        source="OIML R 60 (2000), load-cell hysteresis error; Prandtl-Ishlinskii operator",
        signature=(
            "F_k alone lags and is flattened at its turning points (odd harmonics), by an "
            "amount fixed in newtons, so its relative lag shrinks as the pressure grows; "
            "p_b and x_c unchanged"
        ),
        channels=("F_k",),
        quantities=(
            Quantity("e_h", "-", "hysteresis error at full scale"),
            Quantity("r", "N", "largest play radius of the operator"),
        ),
    )
)


@_outside_law
@dataclass(frozen=True)
class ForceSensorHysteresis(Effect):
    """Force-sensor hysteresis: the load cells read a rate-independent hysteresis loop of F_k.

    Friction in the load cells' seating on the block and the strain gauges' adhesive make the
    reading on unloading differ from that on loading at the same force (OIML R 60's hysteresis
    error, a few 0.01 % of full scale for a sound cell, ten times that for a damaged or badly
    seated one). The truth law is a Prandtl-Ishlinskii operator, a weighted sum of play
    (backlash) operators of radii up to ``r``: the error grows with the load's excursion until
    every play is taken up, is the same at any rate, and has nonlocal memory of the turning
    points. The caliper does not change: p_b and x_c are untouched.
    Source: OIML R 60 (2000), load-cell hysteresis error; Krasnosel'skii and Pokrovskii,
    Systems with Hysteresis (1989), the Prandtl-Ishlinskii operator. No candidate of the
    diagnosis models a transducer's hysteresis (the channel delay is a pure time shift, the
    same at every amplitude): a case with it is ``unexplained``.
    """

    strength: float = 1.0
    hysteresis_error: float = 0.01
    play_radius: float = 300.0
    operators: int = 8

    entry = FORCE_SENSOR_HYSTERESIS
    parameters = (
        STRENGTH,
        Parameter("hysteresis_error", "-", 0.0, 0.05, "e_h, largest error / full scale at 1"),
        Parameter("play_radius", "N", 1.0, 2000.0, "r, the largest play radius"),
        Parameter("operators", "-", 1, 64, "n, play operators summed"),
    )
    diagnosis_model = "none: outside the library (no candidate has a transducer's hysteresis)"

    def __post_init__(self) -> None:
        super().__post_init__()
        if int(self.operators) != self.operators:
            raise EffectError(f"effect {self.name}: operators = {self.operators!r} is not whole")

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> ForceSensorHysteresis:
        """A hysteresis at ``strength`` whose largest play radius is drawn uniform, 150-450 N."""
        radius = float(np.round(rng.uniform(150.0, 450.0), 1))
        return cls(strength=strength, play_radius=radius)

    def law(self, plant: LtiPlant) -> PlayHysteresis:
        """The load cells' hysteresis at this strength (the same on every rig)."""
        del plant
        return PlayHysteresis(
            channel="F_k",
            error=self.strength * self.hysteresis_error * _FORCE_FULL_SCALE,
            radius=self.play_radius,
            operators=int(self.operators),
        )


# -------------------------------------------------------------------- pressure_tap_resonance

PRESSURE_TAP_RESONANCE = _shared(
    EffectEntry(
        name="pressure_tap_resonance",
        title="the bore-pressure transducer sits behind a resonant tapping line",
        physics=(
            "The transducer is connected to the bore through a thin tube ending in its own "
            "dead volume: the fluid in the tube and the volume's compliance make a lightly "
            "damped second-order system between the bore pressure and the reading."
        ),
        source="Bergh and Tijdeman 1965, NLR-TR F.238; Doebelin, Measurement Systems",
        signature=(
            "p_b's amplitude above the prediction by the same share in every segment, with a "
            "small lag; a ringing at the tap's frequency after each segment starts; F_k and "
            "x_c unchanged"
        ),
        channels=("p_b",),
        quantities=(
            Quantity("f_n", "1/s", "natural frequency of tube and dead volume"),
            Quantity("zeta", "-", "damping ratio of the tube's flow"),
        ),
    )
)


@_outside_law
@dataclass(frozen=True)
class PressureTapResonance(Effect):
    """Pressure-tap resonance: p_b is read through a lightly damped tube-and-volume system.

    The bore-pressure transducer is screwed into a tapping line (a thin tube, then the
    transducer's dead volume behind its diaphragm). The fluid column in the tube is a mass on
    the spring of the dead volume's compliance (larger still with a trapped bubble), so the
    reading follows the bore pressure through ``w^2 / (s^2 + 2 zeta w s + w^2)``, a resonance
    at ``f_n = frequency / sqrt(strength)`` (18 Hz at strength 1, 36 Hz at 0.25) with the
    tube's laminar damping ``zeta``. At the 5 Hz pulsing the reading is ``1 / (1 - (5/f_n)^2)``
    times the pressure and lags it slightly; the start of each segment rings. Nothing in the
    caliper changes. Source: Bergh and Tijdeman, NLR-TR F.238 (1965), the dynamic response of
    pressure-measuring systems; Doebelin, Measurement Systems (2004), tubing and volumes.
    The library's channel delay is a pure time shift with unit gain and no candidate
    amplifies a channel: a case with it is ``unexplained``.
    """

    strength: float = 1.0
    frequency: float = 18.0
    damping_ratio: float = 0.1

    entry = PRESSURE_TAP_RESONANCE
    parameters = (
        STRENGTH,
        Parameter("frequency", "1/s", 10.0, 200.0, "f_n at strength 1 (frequency / sqrt(s))"),
        Parameter("damping_ratio", "-", 0.01, 0.7, "zeta of the tube's flow"),
    )
    diagnosis_model = "none: outside the library (no candidate has a resonant transducer)"

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> PressureTapResonance:
        """A tap at ``strength``: ``frequency`` uniform 16-22 Hz, ``zeta`` uniform 0.05-0.2."""
        frequency = float(np.round(rng.uniform(16.0, 22.0), 2))
        damping = float(np.round(rng.uniform(0.05, 0.2), 3))
        return cls(strength=strength, frequency=frequency, damping_ratio=damping)

    def law(self, plant: LtiPlant) -> TapResonance:
        """The tapping line at this strength (the same on every rig)."""
        del plant
        return TapResonance(
            channel="p_b",
            natural_frequency=self.frequency / math.sqrt(self.strength),
            damping_ratio=self.damping_ratio,
        )


# --------------------------------------------------------------------------- pressure_zero_shift

PRESSURE_ZERO_SHIFT = _shared(
    EffectEntry(
        name="pressure_zero_shift",
        title="the bore-pressure transducer's zero shifts with the highest pressure it has seen",
        physics=(
            "A diaphragm transducer loaded to a new peak pressure creeps and does not return "
            "to its zero: its reading gains an offset proportional to the highest pressure so "
            "far, settling in over a creep time after each new peak."
        ),
        source="ISA-S37.1 (1975), zero shift and creep of transducers",
        signature=(
            "p_b offset from the prediction by a constant within each segment, a step at each "
            "higher segment settling in over seconds; its amplitude and phase right; F_k and "
            "x_c unchanged"
        ),
        channels=("p_b",),
        quantities=(
            Quantity("s_z", "-", "zero shift per unit of the peak pressure seen"),
            Quantity("tau_z", "s", "creep time of the shift"),
        ),
    )
)


@_outside_law
@dataclass(frozen=True)
class PressureZeroShift(Effect):
    """Pressure zero shift: p_b's zero moves with the peak pressure the transducer has seen.

    A strain-gauge or piezoresistive diaphragm transducer loaded to a pressure it has not
    seen before creeps (its diaphragm and the gauges' adhesive relax) and does not return to
    its zero afterwards: its reading carries an offset ``z`` that settles, over a creep time
    ``tau_z``, to a share ``s_z`` of the highest pressure so far (``tau_z z' = s_z max p_b -
    z``). Each segment of higher pressure steps the offset and the segment's first seconds
    drift; within a steady segment the reading is offset by a constant. Nothing in the caliper
    changes. Source: ISA-S37.1 (1975), transducer zero shift, creep and hysteresis; OIML
    R 60 (2000), the minimum dead-load output return of load cells, the same law for a force
    transducer. No candidate of the diagnosis offsets a channel, and thermal drift drifts the
    rig's dynamics, not a reading: a case with it is ``unexplained``.
    """

    strength: float = 1.0
    shift: float = 0.015
    creep_time: float = 1.5

    entry = PRESSURE_ZERO_SHIFT
    parameters = (
        STRENGTH,
        Parameter("shift", "-", -0.05, 0.05, "s_z, offset per peak pressure at strength 1"),
        Parameter("creep_time", "s", 0.05, 30.0, "tau_z, the shift's creep time"),
    )
    diagnosis_model = "none: outside the library (no candidate offsets a channel)"

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> PressureZeroShift:
        """A shift at ``strength``: either sign, creep time uniform 0.5-3 s."""
        sign = 1.0 if rng.uniform() < 0.5 else -1.0
        creep = float(np.round(rng.uniform(0.5, 3.0), 3))
        return cls(strength=strength, shift=sign * cls.shift, creep_time=creep)

    def law(self, plant: LtiPlant) -> PeakZeroShift:
        """The transducer's zero shift at this strength (the same on every rig)."""
        del plant
        return PeakZeroShift(
            channel="p_b", shift=self.strength * self.shift, creep_time=self.creep_time
        )


# --------------------------------------------------------------------------- registration

OUTSIDE_LAWS: tuple[type[Effect], ...] = tuple(_DEFINED)
"""The five truth laws, in the order they are defined here (and registered)."""

OUTSIDE_NAMES: tuple[str, ...] = tuple(cls.entry.name for cls in OUTSIDE_LAWS)
"""Their catalogue names."""


def _same_law(registered: type[Effect], cls: type[Effect]) -> bool:
    """True when ``registered`` is ``cls`` or this module's ``cls`` from an earlier import."""
    return registered is cls or (
        registered.__module__ == cls.__module__ and registered.__qualname__ == cls.__qualname__
    )


def register_outside() -> tuple[str, ...]:
    """Register the five laws out of the library; idempotent. Returns the names registered now.

    Each entry goes to ``catalogue.OUT_OF_LIBRARY`` (unless an equal entry is there), then
    its class to the virtual rig's registry (replacing this module's own class of an earlier
    import, as after a reload).

    Raises:
        EffectError: another effect of one of these names is registered (a different entry,
            an entry in the library, or another truth law).
    """
    added = []
    for cls in OUTSIDE_LAWS:
        name = cls.entry.name
        if name in catalogue.CATALOGUE:
            raise EffectError(f"effect {name} is in the library; it cannot be outside it")
        held = catalogue.OUT_OF_LIBRARY.get(name)
        if held is None:
            catalogue.register(cls.entry, in_library=False)
            added.append(name)
        elif held != cls.entry:
            raise EffectError(f"effect {name}: another catalogue entry of that name is registered")
        registered = OUT_OF_LIBRARY.get(name)
        if registered is cls:
            continue
        if registered is not None:
            if not _same_law(registered, cls):
                raise EffectError(
                    f"effect {name} has another truth law already ({registered.__name__})"
                )
            unregister_effect(name)
        register_effect(cls)
    return tuple(added)


def unregister_outside() -> None:
    """Take the five out of the catalogue and the registry (nothing for those not there)."""
    for cls in OUTSIDE_LAWS:
        name = cls.entry.name
        registered = OUT_OF_LIBRARY.get(name)
        if registered is not None and _same_law(registered, cls):
            unregister_effect(name)
        if catalogue.OUT_OF_LIBRARY.get(name) == cls.entry and name not in OUT_OF_LIBRARY:
            catalogue.unregister(name)


register_outside()
