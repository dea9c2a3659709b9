"""The one small interface every effect of the virtual rig shares.

An effect is a frozen dataclass: a ``strength`` (dimensionless, 0 = the LTI rig, 1 = strong)
and its own physical parameters, each declared once with unit and bounds in ``parameters``.
The class docstring's first paragraph is the physical description with its source; the class
attributes ``signature`` (how it shows in a recording) and ``diagnosis_model`` (the simpler law
a diagnosis should fit, and where the simulator is richer) document the rest.

The simulator calls one hook, :meth:`Effect.install`, which puts the effect's bound law into
its slot of the :class:`~brake_hil.virtual_rig.plant.Plant` (seal force, line pressure drop,
compliance, caliper force share, parameter drift, measurement post-processing). An effect at
strength 0 installs nothing, so the run is identical to the run without it.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, fields
import math
from typing import TYPE_CHECKING, Any, ClassVar, NamedTuple, TypeAlias

from brake_hil.errors import EffectError

if TYPE_CHECKING:
    from brake_hil.virtual_rig.plant import Plant


Signal: TypeAlias = Any
"""A float or a float array (SI units as stated): every law runs on one state (Python floats,
the fast path of the solver) or on many at once (arrays: Jacobians, outputs)."""


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

    name: ClassVar[str]
    parameters: ClassVar[tuple[Parameter, ...]]
    signature: ClassVar[str]
    diagnosis_model: ClassVar[str]

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
        """The physical description: the first paragraph of the class docstring."""
        doc = (cls.__doc__ or "").strip()
        return " ".join(doc.split("\n\n")[0].split())

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

    @abstractmethod
    def install(self, plant: Plant) -> Plant:
        """The plant with this effect's law in its slot (the plant unchanged at strength 0)."""
