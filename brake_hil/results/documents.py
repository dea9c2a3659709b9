"""The documents the results database stores, checked before anything of them is written.

A refused key raises :class:`KeyRefusedError` (``key: problem``); the store names the
document around it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
import math
from typing import Any, Final

from brake_hil.analysis.comparison import SUMMARY_KEYS
from brake_hil.errors import BrakeHilError
from brake_hil.results.rows import CalibrationValue, HypothesisRow

__all__ = [
    "CheckedDiagnosis",
    "KeyRefusedError",
    "check_diagnosis",
    "check_metrics",
    "checked_mapping",
]

_DIAGNOSIS_MODELS: Final = ("baseline", "improved")


class KeyRefusedError(BrakeHilError, ValueError):
    """A key of a document is missing or its value refused (the caller names the document)."""

    def __init__(self, key: str, problem: str) -> None:
        super().__init__(f"{key}: {problem}")


def _refuse(key: str, problem: str) -> KeyRefusedError:
    return KeyRefusedError(key, problem)


def checked_mapping(value: object, key: str) -> Mapping[str, Any]:
    """``value`` as a mapping of text keys, or refused under ``key``."""
    if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
        raise _refuse(key, "missing or not a mapping")
    return value


def _number(value: object, key: str, *, positive: bool = False, infinite: bool = False) -> float:
    """A finite float (or +inf with ``infinite``), above 0 with ``positive``."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _refuse(key, f"missing or not a number ({value!r})")
    try:
        number = float(value)
    except OverflowError:
        raise _refuse(key, "not a finite number (too large)") from None
    if math.isnan(number) or (math.isinf(number) and not (infinite and number > 0)):
        raise _refuse(key, f"not a finite number ({number})")
    if positive and number <= 0:
        raise _refuse(key, f"must be above 0 ({number})")
    return number


def _numbers(value: object, key: str) -> dict[str, float]:
    return {name: _number(v, f"{key}.{name}") for name, v in checked_mapping(value, key).items()}


def check_metrics(metrics: object, key: str = "metrics") -> dict[str, dict[str, float]]:
    """Channel -> the paper's three metrics (finite); other metrics are not kept.

    Raises:
        BrakeHilError: a channel without one of them, or a value not finite (the message
            starts with the key, e.g. ``metrics.F_k.nrmse``).
    """
    channels = checked_mapping(metrics, key)
    if not channels:
        raise _refuse(key, "no channel")
    checked: dict[str, dict[str, float]] = {}
    for channel, values in channels.items():
        row = checked_mapping(values, f"{key}.{channel}")
        checked[channel] = {m: _number(row.get(m), f"{key}.{channel}.{m}") for m in SUMMARY_KEYS}
    return checked


@dataclass(frozen=True)
class CheckedDiagnosis:
    """What a diagnosis document holds that the store keeps, checked."""

    effects: tuple[str, ...]
    confidence: float
    explanation: str
    calibration: tuple[CalibrationValue, ...]
    hypotheses: tuple[HypothesisRow, ...]
    metrics: dict[str, dict[str, dict[str, float]]]


def check_diagnosis(document: Mapping[str, Any]) -> CheckedDiagnosis:
    """The stored parts of a ``diagnosis.json`` document, each checked.

    Raises:
        BrakeHilError: a missing key or a value of the wrong type, not finite (a confidence
            outside 0-1, a multiplier or improvement not above 0); the message starts with
            the key (e.g. ``verdict.confidence``).
    """
    top = checked_mapping(document, "document")
    verdict = checked_mapping(top.get("verdict"), "verdict")
    effects = verdict.get("effects")
    if not isinstance(effects, list | tuple) or not all(isinstance(e, str) for e in effects):
        raise _refuse("verdict.effects", "missing or not a list of effect names")
    confidence = _number(verdict.get("confidence"), "verdict.confidence")
    if not 0.0 <= confidence <= 1.0:
        raise _refuse("verdict.confidence", f"outside 0-1 ({confidence})")
    explanation = verdict.get("explanation")
    if not isinstance(explanation, str):
        raise _refuse("verdict.explanation", "missing or not text")
    return CheckedDiagnosis(
        effects=tuple(effects),
        confidence=confidence,
        explanation=explanation,
        calibration=_calibration(top),
        hypotheses=_hypotheses(top.get("hypotheses"), set(effects)),
        metrics={model: _model_metrics(top, model) for model in _DIAGNOSIS_MODELS},
    )


def _model_metrics(top: Mapping[str, Any], model: str) -> dict[str, dict[str, float]]:
    return check_metrics(checked_mapping(top.get(model), model).get("metrics"), f"{model}.metrics")


def _calibration(top: Mapping[str, Any]) -> tuple[CalibrationValue, ...]:
    calibration = checked_mapping(top.get("calibration"), "calibration")
    multipliers = checked_mapping(calibration.get("multipliers"), "calibration.multipliers")
    prior = checked_mapping(calibration.get("prior_sigma"), "calibration.prior_sigma")
    posterior = checked_mapping(calibration.get("posterior_sigma"), "calibration.posterior_sigma")
    improved = checked_mapping(top.get("improved"), "improved")
    parameters = _numbers(improved.get("parameters", {}), "improved.parameters")
    values = []
    for name, multiplier in multipliers.items():
        sigma = _number(prior.get(name), f"calibration.prior_sigma.{name}", positive=True)
        after = _number(posterior.get(name), f"calibration.posterior_sigma.{name}", infinite=True)
        if after < 0:
            raise _refuse(f"calibration.posterior_sigma.{name}", f"below 0 ({after})")
        refit = parameters.get(f"calibration.{name}")
        if refit is not None and refit <= 0:
            raise _refuse(f"improved.parameters.calibration.{name}", f"not above 0 ({refit})")
        values.append(
            CalibrationValue(
                name=name,
                multiplier=_number(multiplier, f"calibration.multipliers.{name}", positive=True),
                prior_sigma=sigma,
                posterior_sigma=after,
                improved_multiplier=refit,
            )
        )
    return tuple(values)


def _hypotheses(raw: object, named: set[str]) -> tuple[HypothesisRow, ...]:
    if not isinstance(raw, list | tuple):
        raise _refuse("hypotheses", "missing or not a list")
    rows: dict[str, HypothesisRow] = {}
    for index, item in enumerate(raw):
        key = f"hypotheses[{index}]"
        entry = checked_mapping(item, key)
        effect = entry.get("effect")
        if not isinstance(effect, str) or not effect:
            raise _refuse(f"{key}.effect", "missing or not an effect name")
        if effect in rows:
            raise _refuse(f"{key}.effect", f"{effect} twice")
        rows[effect] = HypothesisRow(
            effect=effect,
            named=bool(named) and set(effect.split("+")) <= named,
            held_out_improvement=_number(
                entry.get("held_out_improvement"), f"{key}.held_out_improvement", positive=True
            ),
            score=_number(entry.get("score"), f"{key}.score"),
            parameters=_numbers(entry.get("parameters", {}), f"{key}.parameters"),
        )
    return tuple(rows.values())
