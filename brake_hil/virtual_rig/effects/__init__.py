"""The effects the LTI model leaves out, one module each, behind :class:`Effect`.

``EFFECTS`` maps each name of interface.md's effect table to its class; ``OUT_OF_LIBRARY``
the physics no candidate of the diagnosis models (a case with one is labelled
``unexplained``). Make one with
:func:`make_effect` (``make_effect("orifice_flow", 0.5)``) or from the command-line form
``NAME[=STRENGTH][,PARAM=VALUE...]`` with :func:`parse_effect`.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

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

EFFECTS: Mapping[str, type[Effect]] = MappingProxyType(
    {
        cls.name: cls
        for cls in (
            SealStickSlip,
            SealGrooveAsymmetry,
            EntrainedAir,
            OrificeFlow,
            HoseCompliance,
            BoreFriction,
            EccentricLoad,
            ThermalDrift,
            SensorDelay,
        )
    }
)
"""Every effect by its interface.md name, in the table's order."""

OUT_OF_LIBRARY: Mapping[str, type[Effect]] = MappingProxyType(
    {cls.name: cls for cls in (SensorNonlinearity,)}
)
"""Physics outside interface.md's effect table: what ``unexplained`` verdicts are tested on."""


def make_effect(name: str, strength: float = 1.0, **parameters: float | str) -> Effect:
    """The effect ``name`` at ``strength`` with some parameters changed from their defaults.

    Raises:
        EffectError: an unknown effect or parameter, or a value outside its bounds.
    """
    try:
        cls = {**EFFECTS, **OUT_OF_LIBRARY}[name]
    except KeyError:
        known = ", ".join([*EFFECTS, *OUT_OF_LIBRARY])
        raise EffectError(f"unknown effect {name!r} (known: {known})") from None
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
    "make_effect",
    "parse_effect",
]
