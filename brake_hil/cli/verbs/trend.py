"""``brake-hil trend``: each rig's calibrated values and effects across its diagnoses."""

from __future__ import annotations

import argparse
from pathlib import Path

from brake_hil.cli.verb import Verb
from brake_hil.words import counted

__all__ = ["TrendVerb"]


class TrendVerb(Verb):
    """Per rig, one line per finding, then where the page is."""

    name = "trend"
    help = "each rig's calibrated values and effects, each recording's metrics, over time"
    description = (
        "Read the diagnoses of the results database in time order and say, per "
        "rig, which calibrated value drifted, sits off the rig file or left its band far in "
        "one run, and which effect grew (only trends beyond doubt); and, per recording, "
        "which regression or comparison metric left its tolerance; write trend.html, one "
        "self-contained file."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """``--db URL [--rig NAME] [--out DIR] [--baseline FILE]``."""
        parser.add_argument(
            "--db",
            required=True,
            metavar="URL",
            help="the results database: an SQLite file, sqlite:///PATH, or "
            "postgresql://USER@HOST:PORT/DBNAME",
        )
        parser.add_argument(
            "--rig", metavar="NAME", help="only this rig (its name in the rig file)"
        )
        parser.add_argument(
            "--out",
            type=Path,
            help="folder for trend.html and its figures (default: trend/ beside the database "
            "file; for PostgreSQL, trend/ here)",
        )
        parser.add_argument(
            "--baseline",
            type=Path,
            metavar="FILE",
            help="a regress baseline JSON: the reference and tolerances of the stored "
            "regressions' metrics (default: each recording's first run, regress's default "
            "tolerances)",
        )

    def main(self, args: argparse.Namespace) -> int:
        """The findings per rig; the report's path."""
        from brake_hil.app.trend import run_trend

        result = run_trend(args.db, args.rig, args.out, args.baseline)
        for rig in result.rigs:
            print(f"{rig.rig}: {len(rig.rows)} diagnoses")
            for line in rig.summary():
                print(f"  {line}")
        for recording in result.recordings:
            print(
                f"{recording.recording} ({recording.kind}): {counted(len(recording.runs), 'run')}"
            )
            for line in recording.summary():
                print(f"  {line}")
        print(f"report: {result.report_path}")
        return 0
