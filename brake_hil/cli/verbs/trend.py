"""``brake-hil trend``: each rig's calibrated values and effects across its diagnoses."""

from __future__ import annotations

import argparse
from pathlib import Path

from brake_hil.cli.verb import Verb

__all__ = ["TrendVerb"]


class TrendVerb(Verb):
    """Per rig, one line per finding, then where the page is."""

    name = "trend"
    help = "each rig's calibrated values and effects across its stored diagnoses"
    description = (
        "Read the diagnoses of the results database in time order and say, per "
        "rig, which calibrated value drifted or sits off the rig file and which effect grew "
        "(only trends beyond doubt); write trend.html with a figure per rig."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """``--db URL [--rig NAME] [--out DIR]``."""
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

    def main(self, args: argparse.Namespace) -> int:
        """The findings per rig; the report's path."""
        from brake_hil.app.trend import run_trend

        result = run_trend(args.db, args.rig, args.out)
        for rig in result.rigs:
            print(f"{rig.rig}: {len(rig.rows)} diagnoses")
            for line in rig.summary():
                print(f"  {line}")
        print(f"report: {result.report_path}")
        return 0
