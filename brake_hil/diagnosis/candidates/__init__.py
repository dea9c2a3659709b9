"""Candidate models of the diagnosis, one module per effect of the catalogue.

The registry (:mod:`.registry`) holds one candidate per catalogue entry
(:mod:`brake_hil.physics.catalogue`); each candidate's class registers itself where it is
defined (the decorator :func:`register_candidate_class`), and importing this package imports
every module of its folder. :data:`CANDIDATES` lists them in the catalogue's order whenever
it is read, so a candidate added at run time by :func:`register_candidate` (a plug-in, a
test) takes part in every diagnosis from then on.
"""

from __future__ import annotations

import importlib
import pkgutil

from brake_hil.diagnosis.candidates.base import Candidate, own_columns
from brake_hil.diagnosis.candidates.registry import (
    CANDIDATES,
    candidate,
    register_candidate,
    register_candidate_class,
    unregister_candidate,
)

__all__ = [
    "CANDIDATES",
    "Candidate",
    "candidate",
    "own_columns",
    "register_candidate",
    "register_candidate_class",
    "unregister_candidate",
]

for _module in pkgutil.iter_modules(__path__):
    if not _module.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_module.name}")  # its candidate registers itself
del _module
