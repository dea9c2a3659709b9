"""The argument parser of ``brake-hil``, derived from the registered verbs.

Each sub-command is a :class:`~brake_hil.cli.verb.Verb` of :mod:`brake_hil.cli.verbs`; its
sub-parser gets the verb's ``help`` and ``description`` and is filled by its
``add_arguments``. It imports nothing heavy (no numpy, scipy, virtual rig), so
``brake-hil --help`` is quick.
"""

from __future__ import annotations

import argparse

from brake_hil import __version__
from brake_hil.cli.verb import add_database_argument
from brake_hil.cli.verbs import VERBS
from brake_hil.cli.verbs.simulate import (
    EXCITATIONS,
    LTI_EXCITATIONS,
    RELATIVE_TOLERANCE,
    SOLVER_METHOD,
    uses_virtual_rig,
)

__all__ = [
    "EXCITATIONS",
    "LTI_EXCITATIONS",
    "RELATIVE_TOLERANCE",
    "SOLVER_METHOD",
    "add_database_argument",
    "build_parser",
    "uses_virtual_rig",
]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``brake-hil``: one sub-parser per verb, in :data:`VERBS` order."""
    parser = argparse.ArgumentParser(
        prog="brake-hil",
        description=(
            "Hardware-in-the-loop tools for hydraulic disk brakes, after Liette, Dreyer and "
            "Singh (2012): their caliper model (LTI), its peak-to-peak ratio, lag tau/T and "
            "NRMSE per channel (their Tables 4-5), the seal's stiffness and damping (their "
            "Table 3), and a diagnosis of the physics the model leaves out."
        ),
    )
    parser.add_argument("--version", action="version", version=f"brake-hil {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)
    for verb in VERBS.values():
        sub = commands.add_parser(verb.name, help=verb.help, description=verb.description)
        verb().add_arguments(sub)
    return parser
