"""Inputs of the virtual rig: ramp-then-pulse, ramp, sweep, procedure, ABS train, solenoid.

The seed's ramp-then-pulse, a ramp, a 5-25 Hz sweep, a test procedure chaining them with an
ABS-like pulse train, the solenoid.

An :class:`Excitation` is a sampled pressure (Pa, gauge) at the 1 kHz stamps, either the
master-cylinder pressure ``p_i`` (eqs. 21c-f) or the air pressure ``p_a`` behind the master
cylinder (eqs. 21a-f). Between samples the simulator reads it linearly (a first-order hold,
as the LTI model's discretisation does).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
import math

import numpy as np
from scipy.signal import lfilter

from brake_hil.physics.excitation import SAMPLE_RATE_HZ, SEED_MAX_PRESSURES, PulsingSchedule
from brake_hil.physics.lti_model import ModelInput
from brake_hil.physics.rig import Rig
from brake_hil.types import FloatArray
from brake_hil.virtual_rig.effects.base import EffectError

__all__ = [
    "EXCITATION_KINDS",
    "SAMPLE_RATE_HZ",
    "SEED_MAX_PRESSURES",
    "Excitation",
    "abs_pulse_train",
    "air_driven",
    "frequency_sweep",
    "named_excitation",
    "pressure_ramp",
    "procedure",
    "seed_pulsing",
    "seed_pulsing_from",
    "solenoid_pulsing",
    "solenoid_pulsing_from",
]


@dataclass(frozen=True, eq=False)
class Excitation:
    """A sampled input pressure: ``p_i`` or ``p_a`` (Pa) at ``time`` (s, uniform, from 0)."""

    time: FloatArray  # s
    pressure: FloatArray  # Pa (gauge)
    kind: ModelInput  # which pressure this is
    label: str  # what it is, for recordings and labels

    def __post_init__(self) -> None:
        time = np.asarray(self.time, dtype=float)
        pressure = np.asarray(self.pressure, dtype=float)
        if time.ndim != 1 or time.size < 2 or pressure.shape != time.shape:
            raise EffectError(
                f"excitation {self.label!r}: time {time.shape} and pressure {pressure.shape} "
                "must be 1-D of one length (at least 2 samples)"
            )
        if not (np.all(np.isfinite(time)) and np.all(np.isfinite(pressure))):
            raise EffectError(f"excitation {self.label!r}: non-finite samples")
        if np.any(np.diff(time) <= 0.0):
            raise EffectError(f"excitation {self.label!r}: time must increase")

    @property
    def duration(self) -> float:
        """Length of the excitation (s)."""
        return float(self.time[-1] - self.time[0])

    @property
    def air_driven(self) -> bool:
        """True when the input is the air pressure ``p_a`` (eqs. 21a-b)."""
        return self.kind is ModelInput.AIR_PRESSURE


def seed_pulsing(
    max_pressures: Sequence[float] = (1.38e6,),
    *,
    ramp_s: float = 1.0,
    pulsing_s: float = 5.0,
    pulsing_hz: float = 5.0,
    amplitude_fraction: float = 0.22,
) -> Excitation:
    """The seed's master-cylinder pressure: per maximum pressure (Pa), a ramp then pulsing.

    :func:`seed_pulsing_from` of the :class:`~brake_hil.physics.excitation.PulsingSchedule`
    of these arguments; ``SEED_MAX_PRESSURES`` gives the seed's three segments (1.38, 2.07,
    2.76 MPa).
    """
    return seed_pulsing_from(
        PulsingSchedule(
            tuple(max_pressures),
            ramp_s=ramp_s,
            pulsing_s=pulsing_s,
            pulsing_hz=pulsing_hz,
            amplitude_fraction=amplitude_fraction,
            sample_rate_hz=SAMPLE_RATE_HZ,
        )
    )


def seed_pulsing_from(schedule: PulsingSchedule) -> Excitation:
    """The master-cylinder pressure ``p_i`` of a schedule: its sine pulsing (Pa)."""
    time, pressure = schedule.profile()
    label = (
        f"seed pulsing {schedule.pulsing_hz:g} Hz, p_i max {schedule.levels_mpa} MPa, "
        f"{schedule.pulsing_s:g} s each"
    )
    return Excitation(time, pressure, ModelInput.MASTER_CYLINDER_PRESSURE, label)


def pressure_ramp(
    max_pressure: float = 2.76e6,
    *,
    rest_s: float = 0.5,
    rise_s: float = 3.0,
    hold_s: float = 1.0,
    fall_s: float = 3.0,
) -> Excitation:
    """A non-harmonic input: rest, linear rise to ``max_pressure`` (Pa), hold, fall, rest."""
    corners_t = np.cumsum([0.0, rest_s, rise_s, hold_s, fall_s, rest_s])
    corners_p = [0.0, 0.0, max_pressure, max_pressure, 0.0, 0.0]
    time = np.arange(int(round(corners_t[-1] * SAMPLE_RATE_HZ)) + 1) / SAMPLE_RATE_HZ
    pressure = np.interp(time, corners_t, corners_p)
    label = f"ramp to {max_pressure / 1e6:.2f} MPa in {rise_s:g} s, hold {hold_s:g} s, fall"
    return Excitation(time, pressure, ModelInput.MASTER_CYLINDER_PRESSURE, label)


def frequency_sweep(
    mean_pressure: float = 1.08e6,
    amplitude: float = 0.3e6,
    *,
    start_hz: float = 5.0,
    end_hz: float = 25.0,
    ramp_s: float = 1.0,
    sweep_s: float = 10.0,
) -> Excitation:
    """A smooth ramp to ``mean_pressure`` (Pa), then a linear sine sweep (brake-judder band).

    The frequency rises linearly from ``start_hz`` to ``end_hz`` over ``sweep_s``; the
    amplitude (Pa) fades in over the first period.
    """
    ramp = np.arange(int(round(ramp_s * SAMPLE_RATE_HZ))) / SAMPLE_RATE_HZ
    sweep = np.arange(int(round(sweep_s * SAMPLE_RATE_HZ)) + 1) / SAMPLE_RATE_HZ
    rate = (end_hz - start_hz) / sweep_s
    phase = 2.0 * math.pi * (start_hz * sweep + 0.5 * rate * sweep**2)
    fade = np.minimum(sweep * start_hz, 1.0)
    pressure = np.concatenate(
        [
            mean_pressure * (0.5 - 0.5 * np.cos(math.pi * ramp / ramp_s)),
            mean_pressure + amplitude * fade * np.sin(phase),
        ]
    )
    time = np.arange(pressure.size) / SAMPLE_RATE_HZ
    label = (
        f"sweep {start_hz:g}-{end_hz:g} Hz over {sweep_s:g} s, p_i {mean_pressure / 1e6:.2f} "
        f"+- {amplitude / 1e6:.2f} MPa"
    )
    return Excitation(time, pressure, ModelInput.MASTER_CYLINDER_PRESSURE, label)


def solenoid_pulsing(
    rig: Rig,
    max_pressures: Sequence[float] = (1.38e6,),
    *,
    ramp_s: float = 1.0,
    pulsing_s: float = 5.0,
    pulsing_hz: float = 5.0,
    amplitude_fraction: float = 0.22,
    valve_time_constant: float = 0.008,
    pneumatic_time_constant: float = 0.04,
) -> Excitation:
    """The seed's actuation: a regulator ramps the air, a 3-way solenoid pulses it (``p_a``).

    :func:`solenoid_pulsing_from` of the
    :class:`~brake_hil.physics.excitation.PulsingSchedule` of these arguments.
    """
    schedule = PulsingSchedule(
        tuple(max_pressures),
        ramp_s=ramp_s,
        pulsing_s=pulsing_s,
        pulsing_hz=pulsing_hz,
        amplitude_fraction=amplitude_fraction,
        sample_rate_hz=SAMPLE_RATE_HZ,
    )
    return solenoid_pulsing_from(
        rig,
        schedule,
        valve_time_constant=valve_time_constant,
        pneumatic_time_constant=pneumatic_time_constant,
    )


def solenoid_pulsing_from(
    rig: Rig,
    schedule: PulsingSchedule,
    *,
    valve_time_constant: float = 0.008,
    pneumatic_time_constant: float = 0.04,
) -> Excitation:
    """The air pressure ``p_a`` (Pa) that drives the master cylinder through a schedule.

    The schedule's maximum pressures are the intended maximum master-cylinder pressures (Pa);
    the air pressure is scaled by ``A_i / A_a`` (the master cylinder's static gain, eq. 21a).
    A regulator ramps the air; the solenoid switches the air cylinder between supply and a
    vented level as a square wave at ``pulsing_hz``; the valve opens with a first-order lag
    ``valve_time_constant`` (s) and the air cylinder fills and vents with a first-order lag
    ``pneumatic_time_constant`` (s), which round the square into the near-sine the seed
    measured. The command swing is chosen so that the air pressure swings ``+-
    amplitude_fraction`` of its maximum in steady pulsing. Computed at 10 times the sample
    rate, then sampled.
    """
    master = rig.master_cylinder
    gain = (master.diameter / master.air_piston_diameter) ** 2  # A_i / A_a
    oversample = 10
    fine = schedule.scaled(gain).at_rate(schedule.sample_rate_hz * oversample)
    fine_rate, pulsing_hz = fine.sample_rate_hz, fine.pulsing_hz

    def pneumatics(command: FloatArray) -> FloatArray:
        response = command
        for time_constant in (valve_time_constant, pneumatic_time_constant):
            decay = math.exp(-1.0 / (fine_rate * time_constant))
            response = lfilter([1.0 - decay], [1.0, -decay], response)
        return np.asarray(response, dtype=float)

    def square(duration: float) -> FloatArray:
        phase = (
            2.0 * math.pi * pulsing_hz * np.arange(int(round(duration * fine_rate))) / fine_rate
        )
        return np.where(np.sin(phase + 1e-9) >= 0.0, 1.0, -1.0)

    settled = pneumatics(square(20.0 / pulsing_hz))  # a unit square wave, 20 periods
    swing_gain = 0.5 * float(np.ptp(settled[-int(round(fine_rate / pulsing_hz)) :]))
    shape = fine.ramp_shape()
    pulses = square(fine.pulsing_s)
    pieces: list[FloatArray] = []
    for segment in fine.segments:
        pieces.append(segment.start + (segment.mean - segment.start) * shape)
        pieces.append(np.maximum(segment.mean + segment.amplitude / swing_gain * pulses, 0.0))
    air = pneumatics(np.concatenate(pieces))
    air = np.concatenate([[0.0], air])[: air.size : oversample]
    time = np.arange(air.size) / schedule.sample_rate_hz
    label = (
        f"solenoid pulsing {schedule.pulsing_hz:g} Hz, p_i max ~{schedule.levels_mpa} MPa, "
        f"{schedule.pulsing_s:g} s each"
    )
    return Excitation(time, air, ModelInput.AIR_PRESSURE, label)


EXCITATION_KINDS = ("pulsing", "sweep", "ramp", "procedure")
"""The master-cylinder pressures :func:`named_excitation` makes."""
ABS_PERIODS_S = (0.14, 0.22, 0.16, 0.28, 0.12, 0.2, 0.25, 0.15, 0.3, 0.18)
"""The periods (s) an ABS-like train cycles through: 3-8 Hz, never steady."""
PROCEDURE_HOLD_S = 1.0
"""The hold between the parts of a procedure (s): where one ends and the next begins."""


def _blend(start: float, end: float, duration_s: float) -> FloatArray:
    """A half-cosine move from ``start`` to ``end`` (Pa) over ``duration_s``, at 1 kHz."""
    t = np.arange(int(round(duration_s * SAMPLE_RATE_HZ))) / SAMPLE_RATE_HZ
    return np.asarray(start + (end - start) * (0.5 - 0.5 * np.cos(math.pi * t / duration_s)))


def abs_pulse_train(
    level: float = 2.2e6, depth: float = 0.45, *, pulses: int = 14, rest_s: float = 0.5
) -> Excitation:
    """An ABS-like modulated apply: a fast apply, then pressure pulses, then a release.

    The brake is applied to ``level`` (Pa) in 0.1 s and held 0.5 s; each pulse then dumps
    the pressure by ``depth`` (share of ``level``) within a quarter of its period, holds a
    tenth, and rebuilds linearly; the periods cycle through :data:`ABS_PERIODS_S`. A 0.1 s
    release and ``rest_s`` at rest close it.
    """
    corners_t, corners_p = [0.0, rest_s, rest_s + 0.1, rest_s + 0.6], [0.0, 0.0, level, level]
    low = level * (1.0 - depth)
    for k in range(pulses):
        period, start = ABS_PERIODS_S[k % len(ABS_PERIODS_S)], corners_t[-1]
        corners_t += [start + 0.25 * period, start + 0.35 * period, start + period]
        corners_p += [low, low, level]
    corners_t += [corners_t[-1] + 0.1, corners_t[-1] + 0.1 + rest_s]
    corners_p += [0.0, 0.0]
    time = np.arange(int(round(corners_t[-1] * SAMPLE_RATE_HZ)) + 1) / SAMPLE_RATE_HZ
    pressure = np.interp(time, corners_t, corners_p)
    label = f"ABS-like train of {pulses} pulses, {level / 1e6:.2f} MPa less {depth:.0%}"
    return Excitation(time, pressure, ModelInput.MASTER_CYLINDER_PRESSURE, label)


def procedure(
    max_pressures: Sequence[float] = SEED_MAX_PRESSURES,
    *,
    pulsing_s: float = 5.0,
    pulsing_hz: float = 5.0,
) -> Excitation:
    """A test procedure: pulsing at each pressure, a sweep, a slow ramp, an ABS-like train.

    In a row, each after a :data:`PROCEDURE_HOLD_S` hold: :func:`seed_pulsing` at
    ``max_pressures`` (Pa); a 5-25 Hz :func:`frequency_sweep` over ``2 * pulsing_s`` about
    the last pulsing's mean; a release to rest, then a :func:`pressure_ramp` to the highest
    pressure rising and falling over ``0.8 * pulsing_s`` each (at least 1 s); an
    :func:`abs_pulse_train` at 80 % of the highest pressure.
    """
    top = max(max_pressures)
    pulsing = seed_pulsing(max_pressures, pulsing_s=pulsing_s, pulsing_hz=pulsing_hz)
    sweep = frequency_sweep(0.78 * top, 0.22 * top, ramp_s=1.0, sweep_s=2.0 * pulsing_s)
    slow = max(0.8 * pulsing_s, 1.0)
    ramp = pressure_ramp(top, rest_s=PROCEDURE_HOLD_S, rise_s=slow, fall_s=slow)
    train = abs_pulse_train(0.8 * top)
    parts: list[FloatArray] = [pulsing.pressure]
    for part in (sweep.pressure[int(round(SAMPLE_RATE_HZ)) :], ramp.pressure, train.pressure):
        level = float(parts[-1][-1])
        parts.append(np.full(int(round(PROCEDURE_HOLD_S * SAMPLE_RATE_HZ)), level))
        parts.append(_blend(level, float(part[0]), 0.5))
        parts.append(part)
    pressure = np.concatenate(parts)
    time = np.arange(pressure.size) / SAMPLE_RATE_HZ
    label = (
        f"procedure: pulsing {pulsing_hz:g} Hz at "
        f"{', '.join(f'{p / 1e6:.2f}' for p in max_pressures)} MPa, {pulsing_s:g} s each; "
        f"{sweep.label}; {ramp.label}; {train.label}"
    )
    return Excitation(time, pressure, ModelInput.MASTER_CYLINDER_PRESSURE, label)


def named_excitation(
    kind: str, max_pressures: Sequence[float], *, pulsing_s: float, pulsing_hz: float
) -> Excitation:
    """The master-cylinder pressure ``p_i`` of one of :data:`EXCITATION_KINDS`.

    ``pulsing``: :func:`seed_pulsing`; ``ramp``: :func:`pressure_ramp` to the highest of
    ``max_pressures`` (Pa); ``sweep``: 5-25 Hz over ``2 * pulsing_s`` about 78 % of it
    (+- 22 %); ``procedure``: :func:`procedure`.

    Raises:
        EffectError: an unknown kind.
    """
    top = max(max_pressures)
    if kind == "pulsing":
        return seed_pulsing(max_pressures, pulsing_s=pulsing_s, pulsing_hz=pulsing_hz)
    if kind == "ramp":
        return pressure_ramp(top)
    if kind == "sweep":
        return frequency_sweep(0.78 * top, 0.22 * top, sweep_s=2.0 * pulsing_s)
    if kind == "procedure":
        return procedure(max_pressures, pulsing_s=pulsing_s, pulsing_hz=pulsing_hz)
    raise EffectError(f"unknown excitation {kind!r} (known: {', '.join(EXCITATION_KINDS)})")


def air_driven(rig: Rig, excitation: Excitation) -> Excitation:
    """The air pressure ``p_a`` (Pa) that drives a master-cylinder pressure through ``rig``.

    ``p_i`` times the master cylinder's static gain ``A_i / A_a`` (eq. 21a): a proportional
    regulator behind the air cylinder, its lag left to the master cylinder's dynamics.
    """
    master = rig.master_cylinder
    gain = (master.diameter / master.air_piston_diameter) ** 2  # A_i / A_a
    label = f"{excitation.label}, air-driven"
    return Excitation(excitation.time, excitation.pressure * gain, ModelInput.AIR_PRESSURE, label)
