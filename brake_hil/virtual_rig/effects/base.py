"""The one small interface every effect of the virtual rig (a *truth law*) shares.

An effect is a frozen dataclass: a ``strength`` (dimensionless, 0 = the LTI rig, 1 = strong)
and its own physical parameters, each declared once with unit and bounds in ``parameters``.
It points to its entry of the effect catalogue (:mod:`brake_hil.physics.catalogue`), which
gives its ``name`` and ``signature`` (how it shows in a recording). The class docstring's
summary line and the paragraph after it are the physical description of the truth law with
its source; ``diagnosis_model`` says which simpler law a diagnosis should fit and where the
truth law is richer.

The host calls :meth:`Effect.install` once per run: the effect binds its law
(:class:`~brake_hil.virtual_rig.laws.TruthLaw`, the hooks of the host's ports it acts on) to
the truth rig's coefficients. An effect at strength 0 installs nothing, so the run is
identical to the run without it.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, fields
import math
from typing import Any, ClassVar, NamedTuple

import numpy as np

from brake_hil.errors import EffectError
from brake_hil.physics import catalogue
from brake_hil.physics.catalogue import EffectEntry
from brake_hil.virtual_rig.laws import LtiPlant, Signal, TruthLaw

__all__ = [
    "STRENGTH",
    "CatalogueEntryByName",
    "CatalogueSignatureByName",
    "Effect",
    "EffectError",
    "Parameter",
    "Signal",
]


class Parameter(NamedTuple):
    """One parameter of an effect: its unit and plausible bounds (inclusive)."""

    name: str
    unit: str  # SI unit, "-" for dimensionless, "channel" for a channel name
    low: float
    high: float
    description: str
    choices: tuple[str, ...] = ()  # a categorical parameter's allowed values


STRENGTH = Parameter(
    "strength", "-", 0.0, 1.0, "0: the LTI rig (no change); 1: the effect at full strength"
)


@dataclass(frozen=True)
class Effect(ABC):
    """Base of every effect (abstract; see the effect modules)."""

    strength: float = 1.0

    entry: ClassVar[EffectEntry]  # the catalogue entry this truth law makes recordings of
    name: ClassVar[str]  # the entry's name
    signature: ClassVar[str]  # the entry's signature
    parameters: ClassVar[tuple[Parameter, ...]]
    diagnosis_model: ClassVar[str]  # what a diagnosis fits; where the truth law is richer

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "entry" in cls.__dict__:
            cls.name = cls.entry.name
            cls.signature = cls.entry.signature

    def __post_init__(self) -> None:
        declared = {p.name for p in self.parameters}
        given = {f.name for f in fields(self)}
        if declared != given:  # a programming error in an effect module
            raise TypeError(f"{self.name}: parameters {declared} differ from fields {given}")
        for parameter in self.parameters:
            value = getattr(self, parameter.name)
            if parameter.choices:
                if value not in parameter.choices:
                    raise EffectError(
                        f"effect {self.name}: {parameter.name} = {value!r} is not one of "
                        f"{', '.join(parameter.choices)}"
                    )
                continue
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not math.isfinite(value)
                or not parameter.low <= value <= parameter.high
            ):
                raise EffectError(
                    f"effect {self.name}: {parameter.name} = {value!r} {parameter.unit} is "
                    f"outside {parameter.low:g} to {parameter.high:g} {parameter.unit}"
                )

    @property
    def active(self) -> bool:
        """True when the effect changes the rig (strength above zero)."""
        return self.strength > 0.0

    def values(self) -> dict[str, float | str]:
        """Every parameter's value, strength first (JSON-ready)."""
        result: dict[str, float | str] = {}
        for parameter in self.parameters:
            value = getattr(self, parameter.name)
            result[parameter.name] = value if isinstance(value, str) else float(value)
        return result

    @classmethod
    def description(cls) -> str:
        """The physical description: the class docstring's summary and next paragraph, one line."""
        doc = (cls.__doc__ or "").strip()
        return " ".join(" ".join(doc.split("\n\n")[:2]).split())

    def describe(self) -> str:
        """Description, signature, what a diagnosis fits, and the parameter values."""
        lines = [f"{self.name}: {self.description()}", f"  signature: {self.signature}"]
        lines.append(f"  diagnosis fits: {self.diagnosis_model}")
        for parameter in self.parameters:
            value = getattr(self, parameter.name)
            unit = "" if parameter.unit == "-" else f" {parameter.unit}"
            shown = value if isinstance(value, str) else f"{value:g}{unit}"
            lines.append(f"  {parameter.name} = {shown}  ({parameter.description})")
        return "\n".join(lines)

    @classmethod
    def draw(cls, rng: np.random.Generator, strength: float) -> Effect:
        """The effect at ``strength`` as a benchmark case draws it.

        Each categorical parameter (a channel, say) is drawn uniformly from its choices with
        ``rng``, in the order declared; the others keep their defaults.
        """
        chosen = {p.name: str(rng.choice(p.choices)) for p in cls.parameters if p.choices}
        return cls(strength=strength, **chosen)  # type: ignore[arg-type]

    def install(self, plant: LtiPlant) -> TruthLaw | None:
        """This effect's law bound to ``plant``; None when it changes nothing (strength 0)."""
        return self.law(plant) if self.active else None

    @abstractmethod
    def law(self, plant: LtiPlant) -> TruthLaw:
        """The truth law at this strength, bound to the truth rig's coefficients."""


class CatalogueEntryByName:
    """The class's catalogue entry, looked up by its ``name`` when read (a descriptor).

    Set on a family's abstract base after its class body, so that :class:`Effect`'s own hook
    leaves the base alone and every law of the family reads its entry by its name.
    """

    def __get__(self, instance: object, owner: type[Effect]) -> EffectEntry:
        return catalogue.entry(owner.name)


class CatalogueSignatureByName:
    """The signature of the class's catalogue entry, looked up when read (a descriptor)."""

    def __get__(self, instance: object, owner: type[Effect]) -> str:
        return catalogue.entry(owner.name).signature
