"""Every ``brake-hil`` verb, one module per command or small group of commands.

Importing this package defines (and so registers, :data:`brake_hil.cli.verb.VERBS`) every
verb in the order ``brake-hil --help`` lists them. A new command is a new module here
holding one :class:`~brake_hil.cli.verb.Verb` subclass, imported below in its place.
"""

from __future__ import annotations

# isort: off
# The order of these imports is the order of ``brake-hil --help``.
from brake_hil.cli.verbs import compare  # compare, characterize
from brake_hil.cli.verbs import diagnose
from brake_hil.cli.verbs import simulate
from brake_hil.cli.verbs import cases
from brake_hil.cli.verbs import benchmark
from brake_hil.cli.verbs import regress
from brake_hil.cli.verbs import recover
from brake_hil.cli.verbs import fleet
from brake_hil.cli.verbs import trend

# isort: on
from brake_hil.cli.verb import VERBS

__all__ = [
    "VERBS",
    "benchmark",
    "cases",
    "compare",
    "diagnose",
    "fleet",
    "recover",
    "regress",
    "simulate",
    "trend",
]
