"""What every family-b truth law shares: its catalogue entry by name, and its own registry.

Family b is a second realisation of every library effect (:mod:`brake_hil.physics.catalogue`)
by a *different* law from family a's (:mod:`brake_hil.virtual_rig.effects`), so a diagnosis
tuned on the recordings of one family can be judged on the other. A family-b class is an
:class:`~brake_hil.virtual_rig.effects.base.Effect` pointing to the very catalogue entry of
its family-a twin (``entry``, ``name`` and ``signature`` are the same, so its label names the
same effect), registered in its own registry (:func:`register_effect_b`, a class decorator,
:data:`EFFECTS_B`): ``EFFECTS``, ``make_effect`` and the command line keep meaning family a,
whose law is the one truth law family a's registry holds per entry. The entry is therefore
not a class attribute of the family-b class itself but read through :class:`FamilyBEffect`
from the class keyword ``effect`` when it is used, so a law may be defined before its entry is
registered (a plug-in, a test).
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
    "EFFECTS_B",
    "FAMILY_B",
    "FamilyBEffect",
    "register_effect_b",
    "unregister_effect_b",
]

FAMILY_B = "b"
"""The family's name in a case's label."""


@dataclass(frozen=True)
class FamilyBEffect(Effect):
    """Base of the family-b truth laws (abstract): ``class X(FamilyBEffect, effect="name")``."""

    family: ClassVar[str] = FAMILY_B

    def __init_subclass__(cls, effect: str = "", **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if effect:
            cls.name = effect


# set after the class body, so that Effect's own hook (which binds an entry found in a class's
# namespace) leaves the abstract base alone; every family-b class reads them by its name
FamilyBEffect.entry = CatalogueEntryByName()  # type: ignore[assignment]
FamilyBEffect.signature = CatalogueSignatureByName()  # type: ignore[assignment]

_Law = TypeVar("_Law", bound=type[FamilyBEffect])

_REGISTERED: EntryRegistry[type[Effect]] = EntryRegistry("a family-b law")
"""Every family-b truth law by its catalogue name."""

EFFECTS_B: Mapping[str, type[Effect]] = _REGISTERED.view(catalogue.CATALOGUE)
"""Family b's law of every library effect by its name, in the catalogue's order (live)."""


def register_effect_b(cls: _Law) -> _Law:
    """Add the family-b truth law ``cls`` (``class X(FamilyBEffect, effect="name")``).

    A class decorator (outermost, above ``@dataclass``). Register the entry first
    (``catalogue.register``).

    Raises:
        EffectError: ``cls`` is no family-b law naming its effect, the effect is not in the
            library, or it has a family-b law already.
    """
    if not (isinstance(cls, type) and issubclass(cls, FamilyBEffect)) or "name" not in vars(cls):
        raise EffectError(f"{cls!r} is not a FamilyBEffect subclass naming its effect")
    name = cls.name
    if name not in catalogue.CATALOGUE:
        raise EffectError(f"family-b law {cls.__name__}: effect {name} is not in the library")
    _REGISTERED.add(name, cls)
    return cls


def unregister_effect_b(name: str) -> None:
    """Remove the family-b truth law of ``name`` (nothing when there is none)."""
    _REGISTERED.remove(name)
