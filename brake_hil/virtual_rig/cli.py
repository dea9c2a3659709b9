"""Command-line parts of the virtual rig, plugged into ``brake-hil`` (:mod:`brake_hil.cli`).

``brake-hil simulate`` keeps its LTI-model recording unless a virtual-rig option is given
(``--engine virtual``, ``--effect``, ``--excitation``, ``--nominal``, ``--rig-out``, ...);
``brake-hil cases`` writes the concealed-effect benchmark. Both show a tqdm progress bar on
stderr. Work is done by the functions here; :mod:`brake_hil.cli` only parses.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
import sys

from tqdm import tqdm

from brake_hil.errors import BrakeHilError
from brake_hil.physics.rig import Rig, load_rig
from brake_hil.virtual_rig.bag import write_run
from brake_hil.virtual_rig.cases import generate_cases
from brake_hil.virtual_rig.effects import EFFECTS, Effect, parse_effect
from brake_hil.virtual_rig.excitation import (
    Excitation,
    frequency_sweep,
    pressure_ramp,
    seed_pulsing,
    solenoid_pulsing,
)
from brake_hil.virtual_rig.simulator import (
    MAX_STEP,
    RELATIVE_TOLERANCE,
    SOLVER_METHOD,
    simulate_rig,
)

EXCITATIONS = ("pulsing", "solenoid", "ramp", "sweep")
_VIRTUAL_OPTIONS = ("effect", "excitation", "nominal", "rig_out", "method", "rtol")


def add_simulate_arguments(parser: argparse.ArgumentParser) -> None:
    """The virtual-rig options of ``brake-hil simulate``."""
    group = parser.add_argument_group(
        "virtual rig", "any of these (or --engine virtual) simulates the virtual rig"
    )
    group.add_argument(
        "--engine",
        choices=("lti", "virtual"),
        help="lti: the seed's LTI model (the default without virtual-rig options); "
        "virtual: the higher-fidelity rig",
    )
    group.add_argument(
        "--effect",
        action="append",
        metavar="NAME[=STRENGTH][,PARAM=VALUE...]",
        help=f"add an effect (repeatable): {', '.join(EFFECTS)}; strength 0-1 (default 1)",
    )
    group.add_argument(
        "--excitation",
        choices=EXCITATIONS,
        help="pulsing: p_i ramp then 5 Hz (default); solenoid: air pressure through the "
        "master cylinder (eqs. 21a-b); ramp: rise, hold, fall to the highest pressure; "
        "sweep: 5-25 Hz over --pulsing-seconds x 2",
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
    """True when ``simulate`` should run the virtual rig; refuse options it cannot honour."""
    given = [name for name in _VIRTUAL_OPTIONS if getattr(args, name, None) is not None]
    if args.engine == "lti" and given:
        options = ", ".join("--" + name.replace("_", "-") for name in given)
        raise BrakeHilError(f"{options} need the virtual rig; drop --engine lti")
    return args.engine == "virtual" or bool(given)


def _excitation(args: argparse.Namespace, rig: Rig) -> Excitation:
    kind = args.excitation or "pulsing"
    pressures = list(args.max_pressure)
    if kind == "solenoid":
        return solenoid_pulsing(
            rig, pressures, pulsing_s=args.pulsing_seconds, pulsing_hz=rig.excitation_hz
        )
    if kind == "ramp":
        return pressure_ramp(max(pressures))
    if kind == "sweep":
        top = max(pressures)
        return frequency_sweep(0.78 * top, 0.22 * top, sweep_s=2.0 * args.pulsing_seconds)
    return seed_pulsing(pressures, pulsing_s=args.pulsing_seconds, pulsing_hz=rig.excitation_hz)


def _progress_bar(total: float, description: str) -> tuple[tqdm, Callable[[float], None]]:
    bar = tqdm(
        total=round(total, 3),
        unit="s",
        desc=description,
        file=sys.stderr,
        bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} s simulated "
        "[{elapsed}<{remaining}]",
    )

    def update(simulated: float) -> None:
        bar.update(max(0.0, round(simulated, 3) - bar.n))

    return bar, update


def run_virtual_simulate(args: argparse.Namespace) -> Path:
    """``brake-hil simulate`` on the virtual rig: simulate, measure, write bag and rig file."""
    truth = load_rig(args.rig)
    nominal = load_rig(args.nominal) if args.nominal is not None else truth
    if args.out.exists():
        raise BrakeHilError(f"{args.out}: already exists; choose a new output directory")
    effects: list[Effect] = [parse_effect(text) for text in args.effect or []]
    excitation = _excitation(args, truth)
    bar, update = _progress_bar(excitation.duration, "virtual rig")
    try:
        run = simulate_rig(
            truth,
            effects,
            excitation,
            seed=args.seed,
            rtol=args.rtol if args.rtol is not None else RELATIVE_TOLERANCE,
            max_step=MAX_STEP,
            method=args.method or SOLVER_METHOD,
            progress=update,
        )
    finally:
        bar.close()
    rig_path = args.rig_out if args.rig_out is not None else Path(f"{args.out}.rig.yaml")
    write_run(run, args.out, nominal_rig=nominal, rig_path=rig_path)
    names = ", ".join(f"{e.name}={e.strength:g}" for e in run.effects) or "no effect"
    print(f"wrote {args.out} ({run.time.size} samples, {run.time[-1]:.1f} s; {names})")
    print(f"  excitation: {excitation.label}")
    print(f"  rig file (nominal): {rig_path}")
    seconds = run.solver.seconds
    print(f"  solver: {run.solver.method}, {seconds:.1f} s for {excitation.duration:.1f} s")
    out: Path = args.out
    return out


def add_cases_parser(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """The ``brake-hil cases`` sub-command."""
    cases = commands.add_parser(
        "cases", help="write labelled virtual-rig cases for scoring a diagnosis blind"
    )
    cases.add_argument("--out", type=Path, required=True, help="new directory")
    cases.add_argument("--count", type=int, default=26, help="number of cases (26: one round)")
    cases.add_argument("--seed", type=int, default=0)
    cases.add_argument(
        "--pulsing-seconds", type=float, default=5.0, help="per pressure segment (5: 18 s)"
    )
    cases.add_argument("--jobs", type=int, default=1, help="worker processes")
    cases.add_argument(
        "--error-scale", type=float, default=1.0, help="scales the rig tolerances (1 sigma)"
    )
    cases.add_argument(
        "--kind",
        action="append",
        choices=("null", "single", "pair", "unexplained"),
        default=[],
        help="keep only cases of this kind (repeatable; default: every kind)",
    )


def run_cases(args: argparse.Namespace) -> Path:
    """``brake-hil cases``: write the cases and their labels apart."""
    if args.count < 1 or args.jobs < 1 or args.pulsing_seconds <= 0.0:
        raise BrakeHilError("cases: --count and --jobs must be >= 1, --pulsing-seconds > 0")
    if args.out.exists() and (not args.out.is_dir() or any(args.out.iterdir())):
        raise BrakeHilError(f"{args.out}: not empty; choose a new directory for the cases")
    bar = tqdm(total=args.count, unit="case", desc="cases", file=sys.stderr)
    try:
        labels = generate_cases(
            args.out,
            args.count,
            args.seed,
            pulsing_s=args.pulsing_seconds,
            jobs=args.jobs,
            error_scale=args.error_scale,
            kinds=tuple(args.kind),
            progress=lambda _case: bar.update(1),
        )
    finally:
        bar.close()
    print(f"wrote {args.count} cases under {args.out / 'cases'}; labels in {labels}")
    return labels
