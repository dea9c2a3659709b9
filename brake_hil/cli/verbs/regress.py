"""``brake-hil regress``: replay recordings through the model against a baseline."""

from __future__ import annotations

import argparse
from contextlib import ExitStack
from pathlib import Path
import sys
from typing import TYPE_CHECKING

from brake_hil.cli.progress import FleetBar, fleet_bar
from brake_hil.cli.verb import Verb, add_database_argument
from brake_hil.cli.workers import add_workers_arguments, workers_from_args
from brake_hil.words import counted

if TYPE_CHECKING:
    from brake_hil.app.parallel import Outcome
    from brake_hil.app.regress import MetricCheck, Regression, ReplayResult
    from brake_hil.app.regress_plan import Plan

__all__ = ["RegressVerb", "format_checks"]


class RegressVerb(Verb):
    """0 when nothing moved (or a baseline that is not far off was written), else 1.

    Each recording is replayed through ``--model``, else the baseline's model file when it
    names one, else its own rig file (``RECORDING.rig.yaml`` beside it). A path that holds no
    recording, or a recording with no rig file, is skipped with one line on stderr (exit 2
    when nothing is left to replay). A bar of recordings replayed (one with nothing but idle
    counts as done: it is skipped with a note, not failed), drawn once the inputs are checked.
    A baseline written far off (a ptp ratio further from 100 % than twice the spread the rig
    file's tolerances allow) is written and flagged with a warning; the exit is still 0.
    """

    name = "regress"
    help = "replay recordings through the model; their Tables 4-5 metrics vs a baseline"

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """``RECORDING... --baseline F [--model F] [--update] [--db URL]``, the workers."""
        parser.add_argument(
            "recordings",
            type=Path,
            nargs="+",
            help="recordings (or folders of them) to replay; without steady pulsing (a ramp, "
            "a sweep) each segment is scored; a path with no recording, or one with nothing "
            "but idle, is skipped with a note",
        )
        parser.add_argument("--baseline", type=Path, required=True, help="baseline JSON")
        parser.add_argument(
            "--model",
            type=Path,
            help="one model file for every recording (default: the baseline's when it names "
            "one, else RECORDING.rig.yaml beside each recording)",
        )
        parser.add_argument(
            "--update", action="store_true", help="write (or rewrite) the baseline"
        )
        add_database_argument(parser, "default: none")
        add_workers_arguments(parser)

    def main(self, args: argparse.Namespace) -> int:
        """Replay, print each replay and the checks, append to the database; the status."""
        from brake_hil.app.regress import run_regression
        from brake_hil.app.results_db import check_database
        from brake_hil.errors import NoSteadyPulsingError

        workers = workers_from_args(args)
        with ExitStack() as stack:
            bars: list[FleetBar] = []

            def start(plan: Plan) -> None:
                for reason in plan.refused.values():
                    print(f"brake-hil regress: {reason}: skipped", file=sys.stderr)
                check_database(args.db)  # once the inputs are checked: a refusal writes nothing
                bars.append(stack.enter_context(fleet_bar(len(plan.jobs), "regress")))

            def progress(outcome: Outcome[ReplayResult]) -> None:
                bars[0].finished(outcome.ok or isinstance(outcome.error, NoSteadyPulsingError))

            result = run_regression(
                args.recordings,
                args.baseline,
                args.model,
                args.update,
                workers,
                progress,
                start=start,
            )
        _print_replays(result)
        if args.db and result.results:
            from brake_hil.app.results_db import append_regression

            by_model: dict[Path, dict[Path, dict[str, dict[str, float]]]] = {}
            for replay in result.results.values():
                model = Path(replay.model_file)
                by_model.setdefault(model, {})[Path(replay.recording)] = replay.metrics
            for model, replays in by_model.items():
                stored = append_regression(replays, model, args.db)
            print(f"results appended to {stored}")
        return _status(result)


def _print_replays(result: Regression) -> None:
    """Each replay, the totals, each recording skipped, and the checks' table."""
    for key, replay in result.results.items():
        source = result.sources.get(key, "")
        kinds = ", ".join(dict.fromkeys(str(s["kind"]) for s in replay.scored_segments))
        if replay.basis == "non_idle_segments":  # no steady pulsing: every segment scored
            scored = f"{len(replay.scored_segments)} segments ({kinds}), metrics over non-idle"
        else:
            scored = f"{len(replay.segments)} steady segments scored"
            if replay.scored_segments:
                scored += f"; {len(replay.scored_segments)} segments ({kinds}) each scored"
        print(
            f"{key}: {replay.samples} samples ({replay.duration_s:.1f} s) replayed through "
            f"{replay.model_file} ({source}) at {replay.replay_factor:.0f}x real time, {scored}"
        )
    print(
        f"{counted(len(result.results), 'recording')}, {result.data_s:.1f} s of data in "
        f"{result.wall_s:.2f} s wall time"
    )
    for key, reason in result.skipped.items():
        lost = " (in the baseline: FAILED)" if key in result.lost else ""
        print(f"{key}: skipped, nothing to score{lost} -- {reason}")
    if result.checks:
        for line in format_checks(result.checks):
            print(line)


def _far_off_lines(result: Regression) -> list[str]:
    """One line per far-off baseline: which channels, and the model file they came from."""
    lines = []
    for key, channels in result.far_off.items():
        model = result.far_off_models.get(key, result.results[key].model_file)
        lines.append(
            f"baseline for {key} is itself far off: {', '.join(channels)}, further than the "
            f"rig file's tolerances allow: the model {model} does not match this recording"
        )
    return lines


def _status(result: Regression) -> int:
    """Say how the regression ended.

    0 when nothing moved or the baseline was written (a far-off recording in it is flagged
    with a ``WARNING:`` line on stdout and stderr); 1 when a metric moved or a bag of the
    baseline was lost.
    """
    far = _far_off_lines(result)
    if result.updated:
        print(f"baseline written to {result.baseline_path}")
        for line in far:
            print(f"WARNING: {line}")
            print(f"brake-hil regress: WARNING: {line}", file=sys.stderr)
        if far:
            print(
                f"{len(far)} of its {len(result.results)} recordings "
                f"{'is' if len(far) == 1 else 'are'} far off: check each one's rig file "
                "(or --model), or diagnose the recording"
            )
        return 0
    for line in far:
        print(f"note: {line}; within tolerance of it means unchanged, not right")
    if result.moved:
        print(f"{len(result.moved)} metrics moved past their tolerance or have no baseline")
    if result.lost:
        print(f"{counted(len(result.lost), 'recording')} of the baseline no longer scored")
    if result.failed:
        return 1
    if not result.results:
        print("no recording scored")
        return 1
    print("every metric within its tolerance")
    return 0


def format_checks(checks: tuple[MetricCheck, ...]) -> list[str]:
    """The table ``regress`` prints: one line per bag, channel and metric.

    A segment's metric is named after its segment (``sweep 11.0-21.0 s: nrmse``).
    """
    width = max([len(c.bag) for c in checks] + [3])
    names = [f"{c.segment}: {c.metric}" if c.segment else c.metric for c in checks]
    named = max([len(name) for name in names] + [15])
    lines = [
        f"{'bag':{width}s}  {'channel':7s} {'metric':{named}s}{'baseline':>12s}{'now':>12s}"
        f"{'delta':>11s}{'tol':>9s}  status"
    ]
    for c, metric in zip(checks, names):
        baseline = "-" if c.baseline is None else f"{c.baseline:.5g}"
        delta = "-" if c.baseline is None else f"{c.delta:+.3g}"
        lines.append(
            f"{c.bag:{width}s}  {c.channel:7s} {metric:{named}s}{baseline:>12s}{c.value:12.5g}"
            f"{delta:>11s}{c.tolerance:9.3g}  {c.status}"
        )
    return lines
