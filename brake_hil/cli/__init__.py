"""``brake-hil``: the command line of docs/interface.md.

The work of each sub-command is a function of :mod:`brake_hil.app` that returns its result
and prints nothing. Each sub-command is a verb (:mod:`.verb`), one module per command or
small group in :mod:`.verbs`: its arguments, and its ``main`` that calls the app function,
prints the result and progress and returns the exit status. The parser (:mod:`.parser`) and
the dispatch below are derived from the registered verbs. Bad input (a missing file, a
corrupt bag, a missing topic, NaN samples, stamps going backwards, a bad rig key) ends with
one line on stderr naming the file and the problem, and exit status 2.
:mod:`.chain` is the command line of the node-chain launcher
(``python -m brake_hil.nodes.chain``).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
import logging
import sys

from brake_hil.cli.parser import build_parser
from brake_hil.cli.verbs import VERBS
from brake_hil.errors import BrakeHilError

__all__ = ["EXIT_BAD_INPUT", "build_parser", "main"]

EXIT_BAD_INPUT = 2
READER_LOG = "brake_hil.recording"
"""The recording reader's logger (:mod:`brake_hil.io.unfinished`)."""


class _HeldNotes(logging.Handler):
    """Holds the reader's notes (an unfinished recording) while a command runs."""

    def __init__(self) -> None:
        super().__init__(logging.INFO)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        """Keep ``record``."""
        self.records.append(record)

    def lines(self) -> list[str]:
        """The notes, one line each."""
        return [record.getMessage() for record in self.records]

    def briefs(self) -> list[str]:
        """Each note in a few words, once."""
        found = [str(getattr(record, "brief", "")) for record in self.records]
        return list(dict.fromkeys(brief for brief in found if brief))


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``brake-hil`` console script; returns the exit status.

    The recording reader's notes (an unfinished recording read from its whole chunks) go to
    stderr once the command has answered; a refusal stays one line, the note folded into it.
    """
    args = build_parser().parse_args(argv)
    notes = _HeldNotes()
    reader_log = logging.getLogger(READER_LOG)
    propagate = reader_log.propagate
    reader_log.addHandler(notes)
    reader_log.propagate = False
    try:
        status = _run(args)
    except BrakeHilError as err:
        folded = "".join(f" ({brief})" for brief in notes.briefs())
        print(f"brake-hil {args.command}: error: {err}{folded}", file=sys.stderr)
        return EXIT_BAD_INPUT
    finally:
        reader_log.removeHandler(notes)
        reader_log.propagate = propagate
    for line in notes.lines():
        print(line, file=sys.stderr)
    return status


def _run(args: argparse.Namespace) -> int:
    """The verb ``args.command``; its exit status."""
    return VERBS[args.command]().main(args)
