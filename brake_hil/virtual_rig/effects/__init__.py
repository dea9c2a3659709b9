"""The effects the LTI model leaves out: one truth law each, behind :class:`Effect`.

Each truth law points to its entry of the effect catalogue
(:mod:`brake_hil.physics.catalogue`). ``EFFECTS`` maps each name of the library
(``catalogue.CATALOGUE``, interface.md's effect table) to its class, in the catalogue's
order; ``OUT_OF_LIBRARY`` those of ``catalogue.OUT_OF_LIBRARY``, the physics no candidate of
the diagnosis models (a case with one is labelled ``unexplained``). Both are live views:
:func:`register_effect` adds a truth law at run time (a plug-in, a test) once its catalogue
entry exists, :func:`unregister_effect` removes it. Make an effect with :func:`make_effect`
(``make_effect("orifice_flow", 0.5)``) or from the command-line form
``NAME[=STRENGTH][,PARAM=VALUE...]`` with :func:`parse_effect`.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping

from brake_hil.physics import catalogue
from brake_hil.physics.catalogue import EffectEntry
from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, EffectError, Parameter
from brake_hil.virtual_rig.effects.bore_friction import BoreFriction
from brake_hil.virtual_rig.effects.eccentric_load import EccentricLoad
from brake_hil.virtual_rig.effects.entrained_air import EntrainedAir
from brake_hil.virtual_rig.effects.hose_compliance import HoseCompliance
from brake_hil.virtual_rig.effects.orifice_flow import OrificeFlow
from brake_hil.virtual_rig.effects.seal_groove_asymmetry import SealGrooveAsymmetry
from brake_hil.virtual_rig.effects.seal_stick_slip import SealStickSlip
from brake_hil.virtual_rig.effects.sensor_delay import SensorDelay
from brake_hil.virtual_rig.effects.sensor_nonlinearity import SensorNonlinearity
from brake_hil.virtual_rig.effects.thermal_drift import ThermalDrift

_REGISTERED: dict[str, type[Effect]] = {}
"""Every truth law by its catalogue name."""


class _TruthLaws(Mapping[str, type[Effect]]):
    """The registered truth laws of one part of the catalogue, in its order (a live view)."""

    def __init__(self, entries: Mapping[str, EffectEntry]) -> None:
        self._entries = entries

    def __getitem__(self, name: str) -> type[Effect]:
        if name not in self._entries:
            raise KeyError(name)
        return _REGISTERED[name]

    def __iter__(self) -> Iterator[str]:
        return (name for name in self._entries if name in _REGISTERED)

    def __len__(self) -> int:
        return sum(1 for _ in self)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({list(self)})"


EFFECTS: Mapping[str, type[Effect]] = _TruthLaws(catalogue.CATALOGUE)
"""Every effect of the library by its name, in the catalogue's (interface.md's) order."""

OUT_OF_LIBRARY: Mapping[str, type[Effect]] = _TruthLaws(catalogue.OUT_OF_LIBRARY)
"""Physics outside the library (catalogue.OUT_OF_LIBRARY): what ``unexplained`` verdicts
are tested on."""


def register_effect(cls: type[Effect]) -> type[Effect]:
    """Add the truth law ``cls`` (an :class:`Effect` subclass pointing to its catalogue entry).

    Usable as a class decorator. Register the entry first (``catalogue.register``).

    Raises:
        EffectError: ``cls`` is no effect, its entry is not the catalogue's, or a truth law
            of that name is registered already.
    """
    if not (isinstance(cls, type) and issubclass(cls, Effect)) or "entry" not in vars(cls):
        raise EffectError(f"{cls!r} is not an Effect subclass pointing to a catalogue entry")
    name = cls.entry.name
    if catalogue.entry(name) != cls.entry:
        raise EffectError(f"effect {name}: {cls.__name__}'s entry is not the catalogue's")
    if name in _REGISTERED:
        raise EffectError(f"effect {name} has a truth law already ({_REGISTERED[name].__name__})")
    _REGISTERED[name] = cls
    return cls


def unregister_effect(name: str) -> None:
    """Remove the truth law of ``name`` (nothing when there is none)."""
    _REGISTERED.pop(name, None)


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


_BUILT_IN = (
    SealStickSlip,
    SealGrooveAsymmetry,
    EntrainedAir,
    OrificeFlow,
    HoseCompliance,
    BoreFriction,
    EccentricLoad,
    ThermalDrift,
    SensorDelay,
    SensorNonlinearity,
)
"""The truth laws of this package (EFFECTS orders them by the catalogue, not this tuple)."""
for _truth_law in _BUILT_IN:
    register_effect(_truth_law)
del _truth_law


def make_effect(name: str, strength: float = 1.0, **parameters: float | str) -> Effect:
    """The effect ``name`` at ``strength`` with some parameters changed from their defaults.

    Raises:
        EffectError: an unknown effect or parameter, or a value outside its bounds.
    """
    cls = effect_class(name)
    known_parameters = {p.name for p in cls.parameters} - {"strength"}
    if unknown := sorted(set(parameters) - known_parameters):
        raise EffectError(
            f"effect {name}: unknown parameter {unknown[0]!r} "
            f"(known: {', '.join(sorted(known_parameters))})"
        )
    return cls(strength=strength, **parameters)  # type: ignore[arg-type]


def parse_effect(text: str) -> Effect:
    """An effect from ``NAME[=STRENGTH][,PARAM=VALUE...]``, e.g. ``sensor_delay=0.5,channel=p_b``.

    Raises:
        EffectError: the text does not name an effect or holds a bad value.
    """
    head, *rest = text.split(",")
    name, _, strength_text = head.partition("=")
    values: dict[str, float | str] = {}
    for item in rest:
        key, equals, value = item.partition("=")
        if not equals or not key:
            raise EffectError(f"effect {text!r}: expected PARAM=VALUE, got {item!r}")
        values[key.strip()] = _number_or_text(value.strip())
    try:
        strength = float(strength_text) if strength_text else 1.0
    except ValueError:
        raise EffectError(f"effect {text!r}: strength {strength_text!r} is not a number") from None
    return make_effect(name.strip(), strength, **values)


def _number_or_text(value: str) -> float | str:
    try:
        number = float(value)
    except ValueError:
        return value
    return int(number) if number.is_integer() and "." not in value and "e" not in value else number


__all__ = [
    "EFFECTS",
    "OUT_OF_LIBRARY",
    "STRENGTH",
    "BoreFriction",
    "EccentricLoad",
    "Effect",
    "EffectError",
    "EntrainedAir",
    "HoseCompliance",
    "OrificeFlow",
    "Parameter",
    "SealGrooveAsymmetry",
    "SealStickSlip",
    "SensorDelay",
    "SensorNonlinearity",
    "ThermalDrift",
    "effect_class",
    "make_effect",
    "parse_effect",
    "register_effect",
    "unregister_effect",
]
