"""The registry of truth laws: each registers itself where it is defined.

A truth law's class is decorated with :func:`register_effect` in its own module; the package
(:mod:`brake_hil.virtual_rig.effects`) imports every module of its folder, so no list names
them. ``EFFECTS`` and ``OUT_OF_LIBRARY`` are live views in the catalogue's order
(:mod:`brake_hil.physics.catalogue`), whatever order the modules were imported in, so the
cases a seed draws do not depend on it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TypeVar

from brake_hil.physics import catalogue
from brake_hil.physics.catalogue import EntryRegistry
from brake_hil.virtual_rig.effects.base import Effect, EffectError

__all__ = [
    "EFFECTS",
    "OUT_OF_LIBRARY",
    "effect_class",
    "register_effect",
    "unregister_effect",
]

_Law = TypeVar("_Law", bound=type[Effect])

_REGISTERED: EntryRegistry[type[Effect]] = EntryRegistry("a truth law")
"""Every truth law of family a (and the out-of-library laws) by its catalogue name."""

EFFECTS: Mapping[str, type[Effect]] = _REGISTERED.view(catalogue.CATALOGUE)
"""Every effect of the library by its name, in the catalogue's (interface.md's) order."""

OUT_OF_LIBRARY: Mapping[str, type[Effect]] = _REGISTERED.view(catalogue.OUT_OF_LIBRARY)
"""Physics outside the library (catalogue.OUT_OF_LIBRARY): what ``unexplained`` verdicts
are tested on."""


def register_effect(cls: _Law) -> _Law:
    """Add the truth law ``cls`` (an :class:`Effect` subclass pointing to its catalogue entry).

    A class decorator (outermost, above ``@dataclass``). Register the entry first
    (``catalogue.register``).

    Raises:
        EffectError: ``cls`` is no effect, its entry is not the catalogue's, or a truth law
            of that name is registered already.
    """
    if not (isinstance(cls, type) and issubclass(cls, Effect)) or "entry" not in vars(cls):
        raise EffectError(f"{cls!r} is not an Effect subclass pointing to a catalogue entry")
    name = cls.entry.name
    if catalogue.entry(name) != cls.entry:
        raise EffectError(f"effect {name}: {cls.__name__}'s entry is not the catalogue's")
    _REGISTERED.add(name, cls)
    return cls


def unregister_effect(name: str) -> None:
    """Remove the truth law of ``name`` (nothing when there is none)."""
    _REGISTERED.remove(name)


def effect_class(name: str) -> type[Effect]:
    """The truth law of ``name``, in or out of the library.

    Raises:
        EffectError: no truth law of that name.
    """
    try:
        return {**EFFECTS, **OUT_OF_LIBRARY}[name]
    except KeyError:
        known = ", ".join([*EFFECTS, *OUT_OF_LIBRARY])
        raise EffectError(f"unknown effect {name!r} (known: {known})") from None
