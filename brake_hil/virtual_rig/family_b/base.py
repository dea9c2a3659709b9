"""What every family-b truth law shares: its catalogue entry by name, kept off the registry.

Family b is a second realisation of every library effect (:mod:`brake_hil.physics.catalogue`)
by a *different* law from family a's (:mod:`brake_hil.virtual_rig.effects`), so a diagnosis
tuned on the recordings of one family can be judged on the other. A family-b class is an
:class:`~brake_hil.virtual_rig.effects.base.Effect` pointing to the very catalogue entry of
its family-a twin (``entry``, ``name`` and ``signature`` are the same, so its label names the
same effect), but it is not registered: ``EFFECTS``, ``make_effect`` and the command line keep
meaning family a, whose law is the one truth law the registry holds per entry. The entry is
therefore not a class attribute of the family-b class itself but read through
:class:`FamilyBEffect` from the class keyword ``effect``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from brake_hil.physics import catalogue
from brake_hil.physics.catalogue import EffectEntry
from brake_hil.virtual_rig.effects.base import Effect

__all__ = ["FAMILY_B", "FamilyBEffect"]

FAMILY_B = "b"
"""The family's name in a case's label."""


class _CatalogueEntry:
    """The class's catalogue entry, looked up by its ``name`` when read (a descriptor)."""

    def __get__(self, instance: object, owner: type[Effect]) -> EffectEntry:
        return catalogue.entry(owner.name)


@dataclass(frozen=True)
class FamilyBEffect(Effect):
    """Base of the family-b truth laws (abstract): ``class X(FamilyBEffect, effect="name")``."""

    family: ClassVar[str] = FAMILY_B

    def __init_subclass__(cls, effect: str = "", **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if effect:
            entry = catalogue.entry(effect)
            cls.name = entry.name
            cls.signature = entry.signature


# set after the class body, so that Effect's own hook (which binds an entry found in a class's
# namespace) leaves the abstract base alone; every family-b class reads it by its name
FamilyBEffect.entry = _CatalogueEntry()  # type: ignore[assignment]
