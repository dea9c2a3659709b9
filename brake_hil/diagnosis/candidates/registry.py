"""The registry of candidates: each registers itself where it is defined.

A candidate's class is decorated with :func:`register_candidate_class` in its own module; the
package (:mod:`brake_hil.diagnosis.candidates`) imports every module of its folder, so no list
names them. :data:`CANDIDATES` lists them in the catalogue's order
(:mod:`brake_hil.physics.catalogue`) whenever it is read, whatever order the modules were
imported in.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import TypeVar, overload

from brake_hil.diagnosis.candidates.base import Candidate
from brake_hil.errors import EffectError
from brake_hil.physics.catalogue import CATALOGUE, EntryRegistry

__all__ = [
    "CANDIDATES",
    "candidate",
    "register_candidate",
    "register_candidate_class",
    "unregister_candidate",
]

_Class = TypeVar("_Class", bound=type[Candidate])

_REGISTERED: EntryRegistry[Candidate] = EntryRegistry("a candidate")


class _Candidates(Sequence[Candidate]):
    """The registered candidates in the catalogue's order, as they are when read."""

    def _ordered(self) -> tuple[Candidate, ...]:
        return tuple(_REGISTERED.view().values())

    @overload
    def __getitem__(self, index: int) -> Candidate: ...

    @overload
    def __getitem__(self, index: slice) -> Sequence[Candidate]: ...

    def __getitem__(self, index: int | slice) -> Candidate | Sequence[Candidate]:
        return self._ordered()[index]

    def __iter__(self) -> Iterator[Candidate]:
        return iter(self._ordered())

    def __len__(self) -> int:
        return len(self._ordered())

    def __repr__(self) -> str:
        return f"CANDIDATES({', '.join(c.name for c in self)})"


CANDIDATES: Sequence[Candidate] = _Candidates()
"""Every registered candidate, in the catalogue's order (read at call time)."""


def candidate(name: str) -> Candidate:
    """The registered candidate of effect ``name``.

    Raises:
        EffectError: no candidate models that effect.
    """
    found = _REGISTERED.get(name)
    if found is None:
        known = ", ".join(c.name for c in CANDIDATES)
        raise EffectError(f"no candidate for effect {name!r} (known: {known})")
    return found


def register_candidate(item: Candidate) -> Candidate:
    """Add a candidate made at run time (a plug-in, a test) to the diagnosis.

    Raises:
        EffectError: its effect is not in the catalogue (register the entry first, with
            :func:`brake_hil.physics.catalogue.register`), its entry is not the catalogue's,
            or that effect has a candidate already.
    """
    name = item.entry.name
    if name not in CATALOGUE:
        raise EffectError(f"candidate {name}: its effect is not in the catalogue")
    if CATALOGUE[name] != item.entry:
        raise EffectError(f"candidate {name}: its entry is not the catalogue's")
    _REGISTERED.add(name, item)
    return item


def unregister_candidate(name: str) -> None:
    """Remove the candidate of effect ``name`` (nothing when absent)."""
    _REGISTERED.remove(name)


def register_candidate_class(cls: _Class) -> _Class:
    """Register an instance of the candidate class ``cls`` (a class decorator).

    Raises:
        EffectError: as :func:`register_candidate`.
    """
    register_candidate(cls())
    return cls
