"""What every family-c truth law shares: its catalogue entry by name, and its own registry.

Family c is a third realisation of every library effect (:mod:`brake_hil.physics.catalogue`),
written from the physics alone (docs/physics.md, the seed paper and the catalogue's words),
without reading the other families' laws or the diagnosis's candidates, so that the
diagnosis can be judged on recordings no threshold of it was set on. A family-c class points
to the very catalogue entry of the effect it realises (``class X(FamilyCEffect,
effect="name")``, the entry read by name when used, as family b does), and registers itself
in :data:`EFFECTS_C` (:func:`register_effect_c`); family a's registry and the command line's
``--effect`` keep meaning family a.

Family c's own out-of-library effects (what its ``unexplained`` cases are made of) carry
their own :class:`~brake_hil.physics.catalogue.EffectEntry`, kept out of the global catalogue
and registered in :data:`OUTSIDE_C` (:func:`register_outside_c`), so family a's and family b's
cases and the catalogue stay what they were.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, TypeVar

from brake_hil.errors import EffectError
from brake_hil.physics import catalogue
from brake_hil.physics.catalogue import EntryRegistry
from brake_hil.virtual_rig.effects.base import (
    CatalogueEntryByName,
    CatalogueSignatureByName,
    Effect,
)

__all__ = [
    "EFFECTS_C",
    "FAMILY_C",
    "OUTSIDE_C",
    "FamilyCEffect",
    "register_effect_c",
    "register_outside_c",
    "unregister_effect_c",
]

FAMILY_C = "c"
"""The family's name in a case's label."""


@dataclass(frozen=True)
class FamilyCEffect(Effect):
    """Base of the family-c library laws (abstract): ``class X(FamilyCEffect, effect="name")``."""

    family: ClassVar[str] = FAMILY_C

    def __init_subclass__(cls, effect: str = "", **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if effect:
            cls.name = effect


# set after the class body, so that Effect's own hook leaves the abstract base alone
FamilyCEffect.entry = CatalogueEntryByName()  # type: ignore[assignment]
FamilyCEffect.signature = CatalogueSignatureByName()  # type: ignore[assignment]

_Law = TypeVar("_Law", bound=type[FamilyCEffect])
_Outside = TypeVar("_Outside", bound=type[Effect])

_REGISTERED: EntryRegistry[type[Effect]] = EntryRegistry("a family-c law")
"""Every family-c library law by its catalogue name."""

EFFECTS_C: Mapping[str, type[Effect]] = _REGISTERED.view(catalogue.CATALOGUE)
"""Family c's law of every library effect by its name, in the catalogue's order (live)."""

_OUTSIDE: dict[str, type[Effect]] = {}
OUTSIDE_C: Mapping[str, type[Effect]] = _OUTSIDE
"""Family c's out-of-library laws by name, in the order they were registered."""


def register_effect_c(cls: _Law) -> _Law:
    """Add the family-c truth law ``cls`` (a class decorator, outermost, above ``@dataclass``).

    Raises:
        EffectError: ``cls`` is no family-c law naming its effect, the effect is not in the
            library, or it has a family-c law already.
    """
    if not (isinstance(cls, type) and issubclass(cls, FamilyCEffect)) or "name" not in vars(cls):
        raise EffectError(f"{cls!r} is not a FamilyCEffect subclass naming its effect")
    if cls.name not in catalogue.CATALOGUE:
        raise EffectError(f"family-c law {cls.__name__}: effect {cls.name} is not in the library")
    _REGISTERED.add(cls.name, cls)
    return cls


def unregister_effect_c(name: str) -> None:
    """Remove the family-c truth law of ``name`` (nothing when there is none)."""
    _REGISTERED.remove(name)


def register_outside_c(cls: _Outside) -> _Outside:
    """Add a family-c out-of-library law (an :class:`Effect` with its own, unlisted entry).

    Raises:
        EffectError: its name is the library's, or it is registered already.
    """
    if not (isinstance(cls, type) and issubclass(cls, Effect)) or "entry" not in vars(cls):
        raise EffectError(f"{cls!r} is not an Effect subclass with its own entry")
    name = cls.entry.name
    if name in catalogue.CATALOGUE or name in _OUTSIDE:
        raise EffectError(f"family-c out-of-library effect {name} is taken")
    _OUTSIDE[name] = cls
    return cls
