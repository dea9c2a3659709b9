"""Family c: a third realisation of every library effect and of the measurement chain.

Written from the physics alone (docs/physics.md, the seed paper, the catalogue's words), not
from the other families' laws or the diagnosis's candidates, so the diagnosis can be judged
on recordings no threshold of it was set on. Each law registers itself where it is defined
(:func:`register_effect_c`, :data:`EFFECTS_C`, in the catalogue's order); family c's own
out-of-library laws (:mod:`~brake_hil.virtual_rig.family_c.outside`) are in
:data:`OUTSIDE_C`, its ``unexplained`` cases; every case is acquired through
:class:`~brake_hil.virtual_rig.family_c.daq.MeasurementChainC`. Importing the package imports
every module of its folder.
"""

from __future__ import annotations

import importlib
import pkgutil

from brake_hil.virtual_rig.family_c.base import (
    EFFECTS_C,
    FAMILY_C,
    OUTSIDE_C,
    FamilyCEffect,
    register_effect_c,
    register_outside_c,
    unregister_effect_c,
)
from brake_hil.virtual_rig.family_c.daq import DAQ_C, MeasurementChainC

__all__ = [
    "DAQ_C",
    "EFFECTS_C",
    "FAMILY_C",
    "OUTSIDE_C",
    "FamilyCEffect",
    "MeasurementChainC",
    "register_effect_c",
    "register_outside_c",
    "unregister_effect_c",
]

for _module in pkgutil.iter_modules(__path__):
    if not _module.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_module.name}")  # its laws register themselves
del _module
