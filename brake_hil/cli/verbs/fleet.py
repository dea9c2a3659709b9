"""``brake-hil fleet``: the virtual lab of ``trend``'s example."""

from __future__ import annotations

import argparse
from contextlib import ExitStack
from pathlib import Path

from tqdm import tqdm

from brake_hil.cli.progress import progress_bar
from brake_hil.cli.verb import Verb
from brake_hil.cli.workers import add_workers_arguments, workers_from_args

__all__ = ["FleetVerb"]


class FleetVerb(Verb):
    """Two virtual rigs recorded once a day, with a progress bar of recordings written."""

    name = "fleet"
    help = "write a small virtual lab's daily recordings (one rig wearing, one steady)"
    description = (
        "Two virtual rigs recorded once a day: rig-1's seals wear and air collects "
        "in its fluid, rig-2 stays steady. Diagnose them with 'brake-hil diagnose DIR', then "
        "'brake-hil trend'. What was simulated is in DIR/truth.json, which neither reads."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """``--out DIR [--runs N] [--seed S] [--pulsing-seconds S]`` and the workers."""
        parser.add_argument("--out", type=Path, required=True, help="new directory")
        parser.add_argument(
            "--runs", type=int, default=30, help="recordings per rig, one a day (30)"
        )
        parser.add_argument("--seed", type=int, default=0, help="draws the rigs and the noise (0)")
        parser.add_argument(
            "--pulsing-seconds",
            type=float,
            default=5.0,
            help="seconds of steady pulsing per pressure (5: an 18 s recording)",
        )
        add_workers_arguments(parser)

    def main(self, args: argparse.Namespace) -> int:
        """Write the lab; say where, and what to run next."""
        from brake_hil.app.fleet import run_fleet

        with ExitStack() as stack:
            bars: list[tqdm] = []  # type: ignore[type-arg]

            def progress(done: int, total: int) -> None:
                if not bars:
                    bars.append(stack.enter_context(progress_bar(total, "fleet", "recording")))
                bars[0].update(done - bars[0].n)

            result = run_fleet(
                args.out,
                args.runs,
                args.seed,
                pulsing_s=args.pulsing_seconds,
                workers=workers_from_args(args),
                progress=progress,
            )
        print(
            f"wrote {result.recordings} recordings of {', '.join(result.rigs)} under "
            f"{result.out} (what was simulated: {result.truth_path})"
        )
        print(
            f"next: brake-hil diagnose {result.out} --out OUT, then "
            "brake-hil trend --db OUT/results.sqlite"
        )
        return 0
