"""``brake-hil cases``: labelled virtual-rig cases for scoring a diagnosis blind."""

from __future__ import annotations

import argparse
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING

from brake_hil.cli.progress import FleetBar, fleet_bar
from brake_hil.cli.verb import Verb
from brake_hil.cli.workers import add_workers_arguments, workers_from_args

if TYPE_CHECKING:
    from brake_hil.virtual_rig.cases import CaseDrive

__all__ = ["CasesVerb", "case_drive"]


class CasesVerb(Verb):
    """Cases written on the workers, with a progress bar of cases written, failed and left."""

    name = "cases"
    help = "write labelled virtual-rig cases for scoring a diagnosis blind"

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """``--out DIR``, how many cases of which kinds, their drive, the workers' options."""
        parser.add_argument("--out", type=Path, required=True, help="new directory")
        parser.add_argument(
            "--count", type=int, default=26, help="number of cases (26: one round)"
        )
        parser.add_argument("--seed", type=int, default=0, help="draws the cases (0)")
        parser.add_argument(
            "--pulsing-seconds",
            type=float,
            default=5.0,
            help="seconds of steady pulsing per pressure (5: an 18 s recording)",
        )
        add_workers_arguments(parser)
        parser.add_argument(
            "--error-scale",
            type=float,
            default=1.0,
            help="multiplies the rig-value errors drawn (1: as the tolerances state them)",
        )
        parser.add_argument(
            "--kind",
            action="append",
            choices=("null", "single", "pair", "unexplained", "out_of_tolerance", "more_air"),
            default=[],
            help="keep only cases of this kind (repeatable; default: every kind; "
            "out_of_tolerance and more_air need --span contract)",
        )
        parser.add_argument(
            "--span",
            choices=("contract", "seed"),
            default="contract",
            help="how the truth rigs differ from their files: contract (default: every "
            "toleranced value uniform within its tolerance, with and without air) or seed "
            "(each error drawn from a normal of half its tolerance, clipped at one: how the "
            "stored sets were drawn, to replay them)",
        )
        parser.add_argument(
            "--family",
            choices=("a", "b", "c"),
            default="a",
            help="family of truth laws: a (the registered laws, default) or b (a second, "
            "structurally different law per effect and its own measurement chain) or c (a "
            "third, written from the physics alone, with its own chain)",
        )
        parser.add_argument(
            "--excitation-hz",
            type=float,
            default=None,
            help="pulsing frequency of every case (default: the nominal rig's, 5 Hz)",
        )
        parser.add_argument(
            "--excitation",
            choices=("pulsing", "sweep", "ramp", "procedure"),
            default="pulsing",
            help="what drives every case: pulsing (default: ramp then pulsing per pressure); "
            "sweep (5-25 Hz over --pulsing-seconds x 2); ramp (rise, hold, fall to the "
            "highest pressure); procedure (pulsing at each pressure, a 5-25 Hz sweep, a slow "
            "ramp and release, an ABS-like pressure-pulse train, chained)",
        )
        parser.add_argument(
            "--max-pressures",
            type=_megapascals,
            default=None,
            metavar="MPA,MPA,...",
            help="one steady segment per maximum pressure (default: the paper's, 1.38,2.07,2.76)",
        )

    def main(self, args: argparse.Namespace) -> int:
        """Write the cases; say where they and their labels are."""
        from brake_hil.app.cases import CaseOptions, run_cases

        workers = workers_from_args(args)
        with ExitStack() as stack:
            bars: list[FleetBar] = []

            def progress(done: int, failed: int, total: int) -> None:
                if not bars:
                    bars.append(stack.enter_context(fleet_bar(total, "cases", "case")))
                bars[0].count(done, failed)

            options = CaseOptions(
                pulsing_s=args.pulsing_seconds,
                error_scale=args.error_scale,
                kinds=tuple(args.kind),
                family=args.family,
                drive=case_drive(args),
                span=args.span,
            )
            result = run_cases(
                args.out, args.count, args.seed, options, workers=workers, progress=progress
            )
        print(
            f"wrote {result.count} cases under {result.cases_dir}; labels in {result.labels_path}"
        )
        return 0


def case_drive(args: argparse.Namespace) -> CaseDrive:
    """The cases' drive: ``--excitation-hz``, ``--max-pressures``, ``--excitation``."""
    from brake_hil.virtual_rig.cases import SEED_DRIVE, CaseDrive

    excitation = getattr(args, "excitation", "pulsing")
    pressures = SEED_DRIVE.max_pressures if args.max_pressures is None else args.max_pressures
    return CaseDrive(args.excitation_hz, pressures, excitation)


def _megapascals(text: str) -> tuple[float, ...]:
    """``--max-pressures``: comma-separated MPa, in Pa."""
    try:
        return tuple(float(part) * 1e6 for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: give comma-separated pressures in MPa, e.g. 1.0,1.8,2.5"
        ) from None
