"""``brake-hil simulate``: a recording of the paper's LTI model, or of the virtual rig.

:func:`run_simulate` writes the LTI model's answer with the DAQ's noise and quantisation;
:func:`run_virtual_simulate` integrates the virtual rig (the truth rig with effects) and
writes its recording with the nominal rig file beside it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from brake_hil.analysis import signals
from brake_hil.analysis.comparison import predict
from brake_hil.analysis.segment_comparison import operating_pressure
from brake_hil.analysis.segmentation import find_segments
from brake_hil.errors import BrakeHilError
from brake_hil.io.recording_writer import write_recording
from brake_hil.physics.excitation import pulsing_profile
from brake_hil.physics.measurement import SENSORS, measure
from brake_hil.physics.parameters import derive_parameters
from brake_hil.physics.rig import Rig, load_rig
from brake_hil.topics import (
    BLOCK_FORCE,
    BORE_PRESSURE,
    CALIPER_DISPLACEMENT,
    MASTER_CYLINDER_PRESSURE,
)
from brake_hil.types import FloatArray
from brake_hil.virtual_rig.bag import write_run
from brake_hil.virtual_rig.effects import Effect, parse_effect
from brake_hil.virtual_rig.excitation import Excitation, named_excitation, solenoid_pulsing
from brake_hil.virtual_rig.simulator import (
    MAX_STEP,
    RELATIVE_TOLERANCE,
    SOLVER_METHOD,
    RigRun,
    simulate_rig,
)

__all__ = [
    "EXCITATIONS",
    "LTI_EXCITATIONS",
    "LtiSimulation",
    "VirtualSimulation",
    "excitation_of",
    "run_simulate",
    "run_virtual_simulate",
]

EXCITATIONS = ("pulsing", "solenoid", "ramp", "sweep", "procedure")
"""The virtual rig's excitations (see :func:`excitation_of`)."""
LTI_EXCITATIONS = ("pulsing", "ramp", "sweep", "procedure")
"""The LTI model's excitations: those that are a master-cylinder pressure ``p_i``."""


@dataclass(frozen=True)
class LtiSimulation:
    """An LTI-model recording written."""

    out: Path  # the rosbag2 directory
    samples: int
    duration_s: float  # time of the last sample (s)


def run_simulate(
    rig_path: Path,
    out: Path,
    max_pressures: Sequence[float],
    pulsing_s: float,
    seed: int,
    excitation: str = "pulsing",
) -> LtiSimulation:
    """Write the LTI model's recording of an excitation with the DAQ's noise.

    Args:
        rig_path: the rig YAML.
        out: a new rosbag2 directory.
        max_pressures: maximum master-cylinder pressures (Pa), one segment each.
        pulsing_s: seconds of 5 Hz pulsing per segment.
        seed: seed of the sensor noise.
        excitation: one of :data:`LTI_EXCITATIONS` (see :func:`excitation_of`); the model
            is derived at the mean ``p_i`` after the first second for ``pulsing``, else at
            the operating point ``compare`` derives it at
            (:func:`~brake_hil.analysis.segment_comparison.operating_pressure`).

    Returns:
        What was written.

    Raises:
        BrakeHilError: a bad rig file or excitation, or ``out`` exists.
    """
    if excitation not in LTI_EXCITATIONS:
        raise BrakeHilError(
            f"--excitation {excitation}: the LTI model takes {', '.join(LTI_EXCITATIONS)} "
            "(solenoid needs the virtual rig)"
        )
    rig = load_rig(rig_path)
    if out.exists():
        raise BrakeHilError(f"{out}: already exists; choose a new output directory")
    if excitation == "pulsing":
        time, pressure = pulsing_profile(
            max_pressures, pulsing_s=pulsing_s, pulsing_hz=rig.excitation_hz
        )
        operating = float(np.mean(pressure[time > 1.0]))
    else:
        drive = excitation_of(excitation, rig, max_pressures, pulsing_s)
        time, pressure = drive.time, drive.pressure
        operating = _operating_point(time, pressure, rig.excitation_hz)
    outputs = predict(pressure, derive_parameters(rig, operating))
    rng = np.random.default_rng(seed)
    channels = {
        MASTER_CYLINDER_PRESSURE: measure(pressure, SENSORS["p_i"], rng),
        BORE_PRESSURE: measure(outputs["p_b"], SENSORS["p_b"], rng),
        BLOCK_FORCE: measure(outputs["F_k"], SENSORS["F_k"], rng),
        CALIPER_DISPLACEMENT: measure(outputs["x_c"], SENSORS["x_c"], rng),
    }
    write_recording(out, time, channels)
    return LtiSimulation(out, int(time.size), float(time[-1]))


def _operating_point(time: FloatArray, pressure: FloatArray, excitation_hz: float) -> float:
    """Where ``compare`` derives the model for a recording of ``pressure`` (Pa)."""
    rate = 1.0 / float(time[1] - time[0])
    filtered = signals.lowpass(pressure, rate)
    segments = find_segments(time, filtered, rate, excitation_hz)
    return operating_pressure(filtered, time, segments)


def excitation_of(
    kind: str, rig: Rig, max_pressures: Sequence[float], pulsing_s: float
) -> Excitation:
    """The virtual rig's input of one of :data:`EXCITATIONS`.

    Args:
        kind: ``pulsing`` (``p_i`` ramp then 5 Hz), ``solenoid`` (air pressure through the
            master cylinder, eqs. 21a-b), ``ramp`` (rise, hold, fall to the highest
            pressure), ``sweep`` (5-25 Hz over ``2 * pulsing_s``) or ``procedure`` (all
            of these chained with an ABS-like pulse train,
            :func:`~brake_hil.virtual_rig.excitation.procedure`).
        rig: the truth rig (its excitation frequency, its master cylinder).
        max_pressures: maximum master-cylinder pressures (Pa), one segment each.
        pulsing_s: seconds of pulsing per segment.

    Returns:
        The excitation.
    """
    pressures = list(max_pressures)
    if kind == "solenoid":
        return solenoid_pulsing(rig, pressures, pulsing_s=pulsing_s, pulsing_hz=rig.excitation_hz)
    return named_excitation(kind, pressures, pulsing_s=pulsing_s, pulsing_hz=rig.excitation_hz)


@dataclass(frozen=True)
class VirtualSimulation:
    """A virtual-rig recording written, with its nominal rig file."""

    out: Path  # the rosbag2 directory
    rig_path: Path  # the nominal rig YAML written beside it
    run: RigRun
    excitation: Excitation


def run_virtual_simulate(
    rig_path: Path,
    out: Path,
    *,
    max_pressures: Sequence[float],
    pulsing_s: float,
    seed: int,
    effects: Sequence[str] = (),
    excitation: str | None = None,
    nominal_path: Path | None = None,
    rig_out: Path | None = None,
    method: str | None = None,
    rtol: float | None = None,
    progress: Callable[[float, float], None] | None = None,
) -> VirtualSimulation:
    """Simulate the virtual rig, measure it like the DAQ, write the bag and the rig file.

    Args:
        rig_path: the truth rig YAML.
        out: a new rosbag2 directory.
        max_pressures: maximum master-cylinder pressures (Pa), one segment each.
        pulsing_s: seconds of pulsing per segment.
        seed: seed of the sensor noise.
        effects: ``NAME[=STRENGTH][,PARAM=VALUE...]`` each.
        excitation: one of :data:`EXCITATIONS` (``None``: pulsing).
        nominal_path: the rig the engineer believes (default: ``rig_path``).
        rig_out: where the nominal rig YAML goes (default ``OUT.rig.yaml``).
        method: stiff solver (default ``SOLVER_METHOD``).
        rtol: solver tolerance (default ``RELATIVE_TOLERANCE``).
        progress: called now and then with the simulated and the total time (s).

    Returns:
        What was written, with the run.

    Raises:
        BrakeHilError: a bad rig file or effect, ``out`` exists, or the solver failed.
    """
    truth = load_rig(rig_path)
    nominal = load_rig(nominal_path) if nominal_path is not None else truth
    if out.exists():
        raise BrakeHilError(f"{out}: already exists; choose a new output directory")
    parsed: list[Effect] = [parse_effect(text) for text in effects]
    drive = excitation_of(excitation or "pulsing", truth, max_pressures, pulsing_s)

    def report(simulated: float) -> None:
        if progress is not None:
            progress(simulated, drive.duration)

    run = simulate_rig(
        truth,
        parsed,
        drive,
        seed=seed,
        rtol=rtol if rtol is not None else RELATIVE_TOLERANCE,
        max_step=MAX_STEP,
        method=method or SOLVER_METHOD,
        progress=report,
    )
    written_rig = rig_out if rig_out is not None else Path(f"{out}.rig.yaml")
    write_run(run, out, nominal_rig=nominal, rig_path=written_rig)
    return VirtualSimulation(out, written_rig, run, drive)
