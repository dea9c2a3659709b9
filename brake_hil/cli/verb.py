"""A ``brake-hil`` sub-command in one place: a :class:`Verb`, registered on definition.

A verb has a ``name``, a one-line ``help`` (and optionally a longer ``description``),
:meth:`Verb.add_arguments` to fill its sub-parser and :meth:`Verb.main` to run it on the
parsed arguments and return the exit status. Defining a subclass registers it in
:data:`VERBS`; :func:`brake_hil.cli.parser.build_parser` and :func:`brake_hil.cli.main` are
derived from that registry. A verb's module imports nothing heavy at its top (no numpy,
scipy, virtual rig), so ``brake-hil --help`` stays quick: its :meth:`~Verb.main` imports
the :mod:`brake_hil.app` function it calls.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import ClassVar

__all__ = ["RECORDING_HELP", "VERBS", "Verb", "add_database_argument", "json_written"]

VERBS: dict[str, type[Verb]] = {}
"""Every verb by name, in the order defined (the order of ``brake-hil --help``)."""
RECORDING_HELP = "rosbag2 directory (MCAP or sqlite3) or a bare .mcap file"
"""The help of a recording argument."""


class Verb:
    """One sub-command of ``brake-hil``; subclasses register themselves in :data:`VERBS`."""

    name: ClassVar[str]
    help: ClassVar[str]
    description: ClassVar[str | None] = None

    def __init_subclass__(cls, **kwargs: object) -> None:
        """Register the new verb under its ``name``."""
        super().__init_subclass__(**kwargs)
        if cls.name in VERBS:
            raise ValueError(f"two brake-hil verbs named {cls.name!r}")
        VERBS[cls.name] = cls

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """Add the verb's arguments (each with help text) to its sub-parser."""
        raise NotImplementedError

    def main(self, args: argparse.Namespace) -> int:
        """Run the verb on the parsed ``args``; print its result; return the exit status.

        Bad input raises a :class:`~brake_hil.errors.BrakeHilError` for
        :func:`brake_hil.cli.main` to print as one line (exit status 2).
        """
        raise NotImplementedError


def add_database_argument(parser: argparse.ArgumentParser, default: str) -> None:
    """``--db``: the results database a command appends to."""
    parser.add_argument(
        "--db",
        metavar="URL",
        help="results database to append to: an SQLite file, sqlite:///PATH, or a PostgreSQL "
        f"server's postgresql://USER@HOST:PORT/DBNAME (libpq's URL; {default})",
    )


def json_written(path: Path | None) -> None:
    """Say where the JSON went, when it was written."""
    if path is not None:
        print(f"json written to {path}")
