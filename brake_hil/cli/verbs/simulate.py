"""``brake-hil simulate``: a recording of the LTI model or of the virtual rig.

The few values its help shows from the simulator (:data:`EXCITATIONS`,
:data:`SOLVER_METHOD`, :data:`RELATIVE_TOLERANCE`) are repeated here, so the help imports
no numerics; ``test/cli/test_cli_usability.py`` keeps them in step.
"""

from __future__ import annotations

import argparse
from contextlib import ExitStack
from pathlib import Path

from tqdm import tqdm

from brake_hil.cli.progress import progress_bar
from brake_hil.cli.verb import Verb
from brake_hil.errors import BrakeHilError
from brake_hil.physics.catalogue import CATALOGUE

__all__ = [
    "EXCITATIONS",
    "LTI_EXCITATIONS",
    "RELATIVE_TOLERANCE",
    "SOLVER_METHOD",
    "SimulateVerb",
    "simulate_lti",
    "simulate_virtual",
    "uses_virtual_rig",
]

EXCITATIONS = ("pulsing", "solenoid", "ramp", "sweep", "procedure")
"""``brake_hil.app.simulate.EXCITATIONS``."""
LTI_EXCITATIONS = ("pulsing", "ramp", "sweep", "procedure")
"""``brake_hil.app.simulate.LTI_EXCITATIONS``: those ``--engine lti`` takes."""
SOLVER_METHOD = "BDF"
"""``brake_hil.virtual_rig.simulator.SOLVER_METHOD``."""
RELATIVE_TOLERANCE = 1.0e-4
"""``brake_hil.virtual_rig.simulator.RELATIVE_TOLERANCE``."""
_VIRTUAL_OPTIONS = ("effect", "excitation", "nominal", "rig_out", "method", "rtol")


class SimulateVerb(Verb):
    """The LTI model (:func:`simulate_lti`) or the virtual rig (:func:`simulate_virtual`)."""

    name = "simulate"
    help = "write a recording of the LTI model or of the virtual rig"

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """``--rig RIG --out DIR``, the drive and the virtual-rig options."""
        parser.add_argument("--rig", type=Path, required=True, help="the rig to simulate (truth)")
        parser.add_argument("--out", type=Path, required=True, help="new rosbag2 directory")
        parser.add_argument(
            "--max-pressure",
            type=float,
            nargs="+",
            default=[1.38e6],
            help="maximum master-cylinder pressures, Pa (one segment each)",
        )
        parser.add_argument(
            "--pulsing-seconds", type=float, default=5.0, help="5 Hz pulsing per segment, s (5)"
        )
        parser.add_argument("--seed", type=int, default=0, help="sensor-noise seed (0)")
        _add_virtual_rig_arguments(parser)

    def main(self, args: argparse.Namespace) -> int:
        """:func:`simulate_virtual` when :func:`uses_virtual_rig`, else :func:`simulate_lti`."""
        if uses_virtual_rig(args):
            return simulate_virtual(args)
        return simulate_lti(args)


def _add_virtual_rig_arguments(parser: argparse.ArgumentParser) -> None:
    """The virtual-rig options of ``brake-hil simulate``."""
    group = parser.add_argument_group(
        "virtual rig", "any of these (or --engine virtual) simulates the virtual rig"
    )
    group.add_argument(
        "--engine",
        choices=("lti", "virtual"),
        help="lti: the paper's LTI model (the default without virtual-rig options); "
        "virtual: the higher-fidelity rig",
    )
    group.add_argument(
        "--effect",
        action="append",
        metavar="NAME[=STRENGTH][,PARAM=VALUE...]",
        help=f"add an effect (repeatable): {', '.join(CATALOGUE)}; strength 0-1 (default 1)",
    )
    group.add_argument(
        "--excitation",
        choices=EXCITATIONS,
        help="pulsing: p_i ramp then 5 Hz (default); solenoid: air pressure through the "
        "master cylinder (eqs. 21a-b); ramp: rise, hold, fall to the highest pressure; "
        "sweep: 5-25 Hz over --pulsing-seconds x 2; procedure: pulsing at each pressure, a "
        "5-25 Hz sweep, a slow ramp and release, an ABS-like pulse train, chained. With "
        "--engine lti: any but solenoid, on the LTI model",
    )
    group.add_argument(
        "--nominal", type=Path, help="the rig the engineer believes (YAML; default: --rig)"
    )
    group.add_argument(
        "--rig-out", type=Path, help="write the nominal rig YAML here (default OUT.rig.yaml)"
    )
    group.add_argument(
        "--method", choices=("BDF", "Radau", "LSODA"), help=f"stiff solver ({SOLVER_METHOD})"
    )
    group.add_argument("--rtol", type=float, help=f"solver tolerance ({RELATIVE_TOLERANCE:g})")


def uses_virtual_rig(args: argparse.Namespace) -> bool:
    """True when ``simulate`` should run the virtual rig.

    Raises:
        BrakeHilError: a virtual-rig option with ``--engine lti``.
    """
    given = [name for name in _VIRTUAL_OPTIONS if getattr(args, name, None) is not None]
    if args.engine == "lti" and getattr(args, "excitation", None) in LTI_EXCITATIONS:
        given.remove("excitation")  # the LTI model takes any p_i
    if args.engine == "lti" and given:
        options = ", ".join("--" + name.replace("_", "-") for name in given)
        if "excitation" in given:  # the one the LTI model takes in other values
            options = options.replace("--excitation", f"--excitation {args.excitation}")
        raise BrakeHilError(f"{options} need the virtual rig; drop --engine lti")
    return args.engine == "virtual" or bool(given)


def simulate_lti(args: argparse.Namespace) -> int:
    """``brake-hil simulate`` of the LTI model."""
    from brake_hil.app.simulate import run_simulate

    result = run_simulate(
        args.rig,
        args.out,
        args.max_pressure,
        args.pulsing_seconds,
        args.seed,
        getattr(args, "excitation", None) or "pulsing",
    )
    print(f"wrote {result.out} ({result.samples} samples, {result.duration_s:.1f} s)")
    return 0


def simulate_virtual(args: argparse.Namespace) -> int:
    """``brake-hil simulate`` on the virtual rig, with a progress bar of simulated time."""
    from brake_hil.app.simulate import run_virtual_simulate

    with ExitStack() as stack:
        bars: list[tqdm] = []  # type: ignore[type-arg]

        def progress(simulated: float, total: float) -> None:
            if not bars:
                bars.append(
                    stack.enter_context(
                        progress_bar(
                            round(total, 3),
                            "virtual rig",
                            "s",
                            bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} "
                            "s simulated [{elapsed}<{remaining}]",
                        )
                    )
                )
            bars[0].update(max(0.0, round(simulated, 3) - bars[0].n))

        result = run_virtual_simulate(
            args.rig,
            args.out,
            max_pressures=args.max_pressure,
            pulsing_s=args.pulsing_seconds,
            seed=args.seed,
            effects=args.effect or (),
            excitation=args.excitation,
            nominal_path=args.nominal,
            rig_out=args.rig_out,
            method=args.method,
            rtol=args.rtol,
            progress=progress,
        )
    run = result.run
    names = ", ".join(f"{e.name}={e.strength:g}" for e in run.effects) or "no effect"
    print(f"wrote {result.out} ({run.time.size} samples, {run.time[-1]:.1f} s; {names})")
    print(f"  excitation: {result.excitation.label}")
    print(f"  rig file (nominal): {result.rig_path}")
    seconds = run.solver.seconds
    duration = result.excitation.duration
    print(f"  solver: {run.solver.method}, {seconds:.1f} s for {duration:.1f} s")
    return 0
