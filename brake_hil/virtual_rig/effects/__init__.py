"""The effects the LTI model leaves out: one truth law each, behind :class:`Effect`.

Each truth law points to its entry of the effect catalogue
(:mod:`brake_hil.physics.catalogue`) and registers itself where it is defined (the decorator
:func:`register_effect`); importing this package imports every module of its folder.
``EFFECTS`` maps each name of the library (``catalogue.CATALOGUE``, interface.md's effect
table) to its class, in the catalogue's order; ``OUT_OF_LIBRARY`` those of
``catalogue.OUT_OF_LIBRARY``, the physics no candidate of the diagnosis models (a case with
one is labelled ``unexplained``). Both are live views (:mod:`.registry`): a truth law made at
run time (a plug-in, a test) is added by :func:`register_effect` once its catalogue entry
exists, and removed by :func:`unregister_effect`. Make an effect with :func:`make_effect`
(``make_effect("orifice_flow", 0.5)``) or from the command-line form
``NAME[=STRENGTH][,PARAM=VALUE...]`` with :func:`parse_effect`.
"""

from __future__ import annotations

import importlib
import pkgutil

from brake_hil.virtual_rig.effects.base import STRENGTH, Effect, EffectError, Parameter
from brake_hil.virtual_rig.effects.registry import (
    EFFECTS,
    OUT_OF_LIBRARY,
    effect_class,
    register_effect,
    unregister_effect,
)

for _module in pkgutil.iter_modules(__path__):
    if not _module.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_module.name}")  # its truth law registers itself
del _module


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
    "Effect",
    "EffectError",
    "Parameter",
    "effect_class",
    "make_effect",
    "parse_effect",
    "register_effect",
    "unregister_effect",
]
