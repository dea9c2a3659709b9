"""Family b: a second, structurally different truth law for every effect of the library.

Family a (:mod:`brake_hil.virtual_rig.effects`) has one truth law per effect of the catalogue
(:mod:`brake_hil.physics.catalogue`); family b realises the same physics with other laws (a
Bouc-Wen seal instead of LuGre, a Churchill-Usagi valve instead of an orifice with ``C_d(Re)``,
a creeping hose node instead of an RC ladder ...) and acquires its cases through its own
measurement chain (:mod:`~brake_hil.virtual_rig.family_b.daq`), so a diagnosis tuned on one
family's recordings can be judged on the other's. Each law registers itself where it is
defined (:func:`register_effect_b`); importing this package imports every module of its folder
but the out-of-library one. ``EFFECTS_B`` maps each library name to its family-b law, in the
catalogue's order (a live view); its labels name the same effects as family a's.
``OUTSIDE_B`` names the out-of-library effects family b draws for ``unexplained`` cases: those
of :mod:`brake_hil.virtual_rig.family_b.outside` (``OUTSIDE_NAMES``, registered with
:func:`brake_hil.virtual_rig.effects.register_effect` when imported) when that module is
there, else family a's transducer gain; it is looked up on first use.
"""

from __future__ import annotations

from functools import cache
import importlib
import pkgutil
from types import ModuleType

from brake_hil.virtual_rig.effects.base import Effect
from brake_hil.virtual_rig.family_b.base import (
    EFFECTS_B,
    FAMILY_B,
    FamilyBEffect,
    register_effect_b,
    unregister_effect_b,
)
from brake_hil.virtual_rig.family_b.daq import DAQ_B, MeasurementChainB

__all__ = [
    "DAQ_B",
    "EFFECTS_B",
    "FAMILY_B",
    "OUTSIDE_B",
    "FamilyBEffect",
    "MeasurementChainB",
    "is_family_b_law",
    "outside_names",
    "register_effect_b",
    "unregister_effect_b",
]

_OUTSIDE_MODULE = "brake_hil.virtual_rig.family_b.outside"
_OUTSIDE_FALLBACK = ("sensor_nonlinearity",)

for _module in pkgutil.iter_modules(__path__):
    name = f"{__name__}.{_module.name}"
    if not _module.name.startswith("_") and name != _OUTSIDE_MODULE:  # that one on first use
        importlib.import_module(name)  # its truth law registers itself
del _module, name

OUTSIDE_B: tuple[str, ...]
"""Out-of-library effects family b draws for ``unexplained`` cases (see the module docstring)."""


@cache
def _outside_module() -> ModuleType | None:
    """The family-b out-of-library module, imported once; None when it is absent."""
    try:
        return importlib.import_module(_OUTSIDE_MODULE)
    except ModuleNotFoundError as error:
        if error.name != _OUTSIDE_MODULE:
            raise
        return None


def outside_names() -> tuple[str, ...]:
    """``OUTSIDE_NAMES`` of the family-b out-of-library module, or family a's when it is absent.

    Their truth laws are registered (again, if something took them out) before the names are
    given, so :func:`brake_hil.virtual_rig.effects.effect_class` finds every one.
    """
    module = _outside_module()
    names = getattr(module, "OUTSIDE_NAMES", None)
    if not names:
        return _OUTSIDE_FALLBACK
    register = getattr(module, "register_outside", None)
    if register is not None:
        register()  # idempotent
    return tuple(str(name) for name in names)


def is_family_b_law(cls: type[Effect]) -> bool:
    """True when the truth law ``cls`` is family b's (its module is in this package).

    Family b's out-of-library laws are registered alongside family a's; family a leaves them
    out, so its cases stay what they were.
    """
    return cls.__module__.startswith(__name__ + ".")


def __getattr__(name: str) -> tuple[str, ...]:
    if name == "OUTSIDE_B":
        return outside_names()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
