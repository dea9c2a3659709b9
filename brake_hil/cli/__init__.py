"""``brake-hil``: the command line of interface.md.

The work of each sub-command is a function of :mod:`brake_hil.app` that returns its result
and prints nothing; this package parses the arguments (:mod:`.parser`), prints the results
and progress (:mod:`.commands`) and sets the exit status. Bad input (a missing file, a
corrupt bag, a missing topic, NaN samples, stamps going backwards, a bad rig key) ends with
one line on stderr naming the file and the problem, and exit status 2.
:mod:`.chain` is the command line of the node-chain launcher
(``python -m brake_hil.nodes.chain``).
"""

from __future__ import annotations

from collections.abc import Sequence
import sys

from brake_hil.cli import commands
from brake_hil.cli.parser import build_parser, uses_virtual_rig
from brake_hil.errors import BrakeHilError

__all__ = ["EXIT_BAD_INPUT", "build_parser", "main"]

EXIT_BAD_INPUT = 2


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``brake-hil`` console script; returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        if args.command == "compare":
            return commands.compare(args)
        if args.command == "characterize":
            return commands.characterize(args)
        if args.command == "diagnose":
            return commands.diagnose(args)
        if args.command == "simulate" and uses_virtual_rig(args):
            return commands.simulate_virtual(args)
        if args.command == "simulate":
            return commands.simulate_lti(args)
        if args.command == "cases":
            return commands.cases(args)
        if args.command == "benchmark":
            return commands.benchmark(args)
        if args.command == "regress":
            return commands.regress(args)
        if args.command == "recover":
            return commands.recover(args)
    except BrakeHilError as err:
        print(f"brake-hil {args.command}: error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    return 0
