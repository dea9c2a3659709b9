"""``brake-hil regress``: replay recordings through the model against a baseline."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from brake_hil.cli.progress import fleet_bar
from brake_hil.cli.verb import Verb, add_database_argument
from brake_hil.cli.workers import add_workers_arguments, workers_from_args

if TYPE_CHECKING:
    from brake_hil.app.parallel import Outcome
    from brake_hil.app.regress import MetricCheck, Regression, ReplayResult

__all__ = ["RegressVerb", "format_checks"]


class RegressVerb(Verb):
    """0 when nothing moved (or the baseline was written), else 1.

    A bar of recordings replayed (one without steady pulsing counts as done: it is skipped
    with a note, not failed), from before the baseline and model are read: their refusal
    comes sooner than the bar's first draw.
    """

    name = "regress"
    help = "replay recordings through the model vs a baseline"

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """``RECORDING... --baseline F [--model F] [--update] [--db URL]``, the workers."""
        parser.add_argument(
            "recordings",
            type=Path,
            nargs="+",
            help="recordings to replay; one without steady 5 Hz pulsing is skipped with a note",
        )
        parser.add_argument("--baseline", type=Path, required=True, help="baseline JSON")
        parser.add_argument("--model", type=Path, help="model file (default: the baseline's)")
        parser.add_argument("--update", action="store_true", help="rewrite the baseline")
        add_database_argument(parser, "default: none")
        add_workers_arguments(parser)

    def main(self, args: argparse.Namespace) -> int:
        """Replay, print each replay and the checks, append to the database; the status."""
        from brake_hil.app.regress import run_regression
        from brake_hil.app.results_db import check_database
        from brake_hil.errors import NoSteadyPulsingError

        workers = workers_from_args(args)
        check_database(args.db)
        with fleet_bar(len(args.recordings), "regress") as bar:

            def progress(outcome: Outcome[ReplayResult]) -> None:
                bar.finished(outcome.ok or isinstance(outcome.error, NoSteadyPulsingError))

            result = run_regression(
                args.recordings, args.baseline, args.model, args.update, workers, progress
            )
        _print_replays(result)
        if args.db and result.results:
            from brake_hil.app.results_db import append_regression

            replays = {Path(r.recording): r.metrics for r in result.results.values()}
            print(f"results appended to {append_regression(replays, result.model_file, args.db)}")
        return _status(result)


def _print_replays(result: Regression) -> None:
    """Each replay, the totals, each recording skipped, and the checks' table."""
    for key, replay in result.results.items():
        print(
            f"{key}: {replay.samples} samples ({replay.duration_s:.1f} s) replayed through "
            f"{result.model_file} at {replay.replay_factor:.0f}x real time, "
            f"{len(replay.segments)} steady segments scored"
        )
    print(
        f"{len(result.results)} recordings, {result.data_s:.1f} s of data in "
        f"{result.wall_s:.2f} s wall time"
    )
    for key, reason in result.skipped.items():
        lost = " (in the baseline: FAILED)" if key in result.lost else ""
        print(f"{key}: skipped, no steady 5 Hz pulsing to score{lost} -- {reason}")
    if result.checks:
        for line in format_checks(result.checks):
            print(line)


def _status(result: Regression) -> int:
    """Say how the regression ended; 0 when the baseline was written or nothing moved."""
    if result.updated:
        print(f"baseline written to {result.baseline_path}")
        return 0
    if result.moved:
        print(f"{len(result.moved)} metrics moved past their tolerance or have no baseline")
    if result.lost:
        print(f"{len(result.lost)} recordings of the baseline no longer hold steady pulsing")
    if result.failed:
        return 1
    if not result.results:
        print("no recording scored")
        return 1
    print("every metric within its tolerance")
    return 0


def format_checks(checks: tuple[MetricCheck, ...]) -> list[str]:
    """The table ``regress`` prints: one line per bag, channel and metric."""
    width = max([len(c.bag) for c in checks] + [3])
    lines = [
        f"{'bag':{width}s}  {'channel':7s} {'metric':15s}{'baseline':>12s}{'now':>12s}"
        f"{'delta':>11s}{'tol':>9s}  status"
    ]
    for c in checks:
        baseline = "-" if c.baseline is None else f"{c.baseline:.5g}"
        delta = "-" if c.baseline is None else f"{c.delta:+.3g}"
        lines.append(
            f"{c.bag:{width}s}  {c.channel:7s} {c.metric:15s}{baseline:>12s}{c.value:12.5g}"
            f"{delta:>11s}{c.tolerance:9.3g}  {c.status}"
        )
    return lines
