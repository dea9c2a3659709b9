"""``brake-hil recover``: a finished copy of an unfinished MCAP recording."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from brake_hil.cli.verb import Verb

if TYPE_CHECKING:
    from brake_hil.app.recover import RecoverResult

__all__ = ["RecoverVerb", "format_recovery"]


class RecoverVerb(Verb):
    """0 when a finished copy was written."""

    name = "recover"
    help = "write a finished copy of an unfinished MCAP recording (kill -9, full disk)"
    description = (
        "Read every whole chunk of a recording a writer did not finish (no "
        "summary, a cut file, metadata.yaml missing or stale) and write them into a new "
        "rosbag2 directory with summaries, indexes, statistics and a matching metadata.yaml. "
        "The input is never written to."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """``BAG [--out DIR]``."""
        parser.add_argument(
            "bag", type=Path, help="rosbag2 directory of .mcap files, or a .mcap file"
        )
        parser.add_argument(
            "--out", type=Path, help="new rosbag2 directory (default: BAG_recovered beside BAG)"
        )

    def main(self, args: argparse.Namespace) -> int:
        """The verdict, one line per file, one per topic."""
        from brake_hil.app.recover import run_recover

        result = run_recover(args.bag, args.out)
        for line in format_recovery(result):
            print(line)
        return 0


def format_recovery(result: RecoverResult) -> list[str]:
    """What ``recover`` prints: the verdict, one line per file, one per topic."""
    state = f"unfinished ({result.reason})" if result.reason else "finished already"
    lines = [
        f"{result.source}: {state}; {result.message_count} messages in "
        f"{len(result.files)} files written to {result.output} (summaries, indexes, "
        "statistics, metadata.yaml)"
    ]
    for item in result.files:
        if item.finished:
            how = "finished"
        else:
            how = f"{item.stop}; {item.lost_bytes} bytes after the last whole record dropped"
        skipped = f", {item.skipped} without channel or schema left out" if item.skipped else ""
        names = f"{item.source.name} -> {item.output.name}"
        lines.append(f"  {names}: {item.messages} messages{skipped} ({how})")
    lines += [f"  {name} ({msgtype}): {count} messages" for name, msgtype, count in result.topics]
    return lines
