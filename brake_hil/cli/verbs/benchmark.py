"""``brake-hil benchmark``: score the diagnosis blind on labelled cases."""

from __future__ import annotations

import argparse
from contextlib import ExitStack
import math
from pathlib import Path
import sys
from typing import TYPE_CHECKING

from brake_hil.cli.progress import FleetBar, fleet_bar
from brake_hil.cli.verb import Verb, json_written
from brake_hil.cli.workers import add_workers_arguments, workers_from_args

if TYPE_CHECKING:
    from brake_hil.app.benchmark import CaseResult

__all__ = ["BenchmarkVerb"]

_ROWS = (
    ("top-1 accuracy, single effects", "top1_accuracy_single", "single_effect_cases"),
    ("exact-set accuracy, pairs", "exact_set_accuracy_pairs", "pair_cases"),
    ("false-positive rate, null cases", "false_positive_rate_null", "null_cases"),
    ("  degassed nulls", "false_positive_rate_null_degassed", "null_cases_degassed"),
    (
        "  nulls with the rig file's air",
        "false_positive_rate_null_rig_file",
        "null_cases_rig_file",
    ),
    ("rig value far off, null cases", "null_rig_value_alarm_rate", "null_cases"),
    ("unexplained recall", "unexplained_recall", "unexplained_cases"),
    ("out-of-tolerance value found", "out_of_tolerance_found", "out_of_tolerance_cases"),
    ("more-air recall", "more_air_recall", "more_air_cases"),
    (
        "'more air', nulls with rig file's air",
        "more_air_false_alarm_rate_rig_file_nulls",
        "null_cases_rig_file",
    ),
)
"""The shares printed: their label, figure and the count of cases they are over."""


class BenchmarkVerb(Verb):
    """A bar of cases, a line per case as its verdict comes in, then the figures.

    A figure over no case is ``n/a``.
    """

    name = "benchmark"
    help = "score the diagnosis blind on labelled cases"

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """``DIRECTORY [--json F]`` and the workers' options."""
        parser.add_argument("directory", type=Path, help="made by 'brake-hil cases'")
        add_workers_arguments(parser)
        parser.add_argument("--json", type=Path, help="also write the figures here as JSON")
        parser.add_argument(
            "--keep",
            type=Path,
            metavar="DIR",
            help="write each case's diagnosis.json to DIR/<case>/ (a new or empty folder)",
        )

    def main(self, args: argparse.Namespace) -> int:
        """0, or 1 when the diagnosis failed on a case (an internal error)."""
        from brake_hil.app.benchmark import INTERNAL_ERROR, case_count, run_benchmark

        workers = workers_from_args(args)
        with ExitStack() as stack:
            bars: list[FleetBar] = []

            def start() -> None:  # once the cases are known to exist: bad input stays one line
                bars.append(stack.enter_context(fleet_bar(count, "benchmark", "case")))

            def show(result: CaseResult) -> None:
                if not bars:
                    start()
                verdict = ", ".join(result.effects) or "none"
                bars[0].write(
                    f"case {result.case}: {verdict} ({result.confidence:.2f}, "
                    f"{result.seconds:.1f} s)"
                    + (f" error: {result.error}" if result.error else "")
                )
                bars[0].finished(not result.error)

            count = case_count(args.directory)
            if count and (args.directory / "labels.json").is_file():
                start()
            result = run_benchmark(args.directory, workers, args.json, show, args.keep)
        print_figures(result.figures)
        json_written(result.json_path)
        failed = [r.case for r in result.results if r.error.startswith(INTERNAL_ERROR)]
        if failed:
            print(
                f"brake-hil benchmark: {args.directory}: the diagnosis failed on {len(failed)} "
                f"case(s) (an internal error, scored as none; the errors are in the JSON): "
                + ", ".join(failed),
                file=sys.stderr,
            )
            return 1
        return 0


def print_figures(figures: dict[str, object]) -> None:
    """The figures of :func:`~brake_hil.app.benchmark.score`, one a line, then reliability.

    Then, when the set holds more than one family of truth laws, each family's.
    """
    _print_block(figures)
    mean = _figure(figures["seconds_per_recording_mean"], 1.0, "6.1f")
    most = _figure(figures["seconds_per_recording_max"], 1.0, ".1f")
    print(f"{'seconds per recording, mean / max':40s}{mean} / {most}")
    families = figures.get("by_family") or {}
    if len(families) > 1:  # type: ignore[arg-type]
        for family, block in families.items():  # type: ignore[attr-defined]
            print(f"-- family {family}")
            _print_block(block)


def _print_block(figures: dict[str, object]) -> None:
    """One block of figures (all cases, or one family's)."""
    for text, key, cases_key in _ROWS:
        share = _figure(figures[key], 100.0, "6.1f", " %")
        print(f"{text:40s}{share}  of {figures[cases_key]} cases")
    improvement = _figure(figures["held_out_rms_improvement_median"], 1.0, "6.2f", " x")
    print(f"{'held-out RMS improvement, median':40s}{improvement}")
    wrong = _figure(figures["wrong_share_of_sure_verdicts"], 100.0, "6.1f", " %")
    print(
        f"{'wrong among verdicts at >= 0.9':40s}{wrong}  "
        f"({figures['wrong_sure_count']} of {figures['sure_verdicts']} verdicts)"
    )
    print("confidence     cases  mean  right")
    for row in figures["reliability"]:  # type: ignore[attr-defined]
        low, high = row["confidence"]
        print(
            f"{low:4.2f}-{high:4.2f}  {row['cases']:7d}  {row['mean_confidence']:4.2f}  "
            f"{100 * row['accuracy']:5.1f} %"
        )


def _figure(value: object, scale: float, spec: str, suffix: str = "") -> str:
    """A figure of :func:`~brake_hil.app.benchmark.score`; ``n/a`` when over no case (NaN)."""
    if not isinstance(value, int | float) or math.isnan(value):
        width = spec.split(".")[0]
        return f"{'n/a':>{width or 0}s}" + (" " * len(suffix) if suffix else "")
    return f"{scale * value:{spec}}{suffix}"
