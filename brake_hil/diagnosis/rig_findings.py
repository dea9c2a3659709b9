"""Rig values far outside their tolerance, and the air against the rig file's: the words.

After the calibration (tolerances propagated, :mod:`.tolerance_prior`) a calibrated quantity
whose fitted multiplier ``m`` lies far outside the band its tolerance allows is a finding about
the rig file, not physics (``verdict.rig_values``). The rule (:func:`outside`): ``|log m|``
more than ``FLAG_SIGMAS`` (2) prior sigmas, and its interval of two posterior sigmas wholly
outside the one-sigma band (a value the recording cannot pin down is not named). A rig whose
values all lie within their tolerance puts a value one key sets at most 1 sigma off, and one
several keys set about 0.6 sigma (one sigma of a sum of uniform draws); a value at twice its
tolerance below the rig file's is 2.2 sigmas or more off (found), one twice its tolerance
above only 1.4-1.8 sigmas (a +-10 % tolerance taken as a log-sigma): not found.

The air (``verdict.air``): the air fraction the improved model carries (the calibrated
fraction, plus the ``entrained_air`` candidate's pressure-following air expressed at the
recording's mean pressure) against the rig file's. It is said whenever entrained_air is named,
or the calibrated fraction is outside its band as any rig value (:func:`outside`), or, where a
pair with entrained air beside the single named cuts what it leaves (the air shows), outside
its tolerance: more than ``1 + tolerance`` times the rig file's (2 for the default 100 %) and
surely (two posterior sigmas) above ``AIR_MORE_RATIO`` times it (the bundled hose recording's
calibration put 1.6 times the air beside the hose's own compliance; a 1.6 threshold alone
called it more air). Where nothing shows the air, the calibrated fraction is one compliance
among the calibrated values, and on fresh recordings whose air was the rig file's it reached
2.0-2.6 times it beside a drift, a probe's play or a sensor's nonlinearity: "bleed" was false.
More than ``AIR_MORE_RATIO`` times the rig file's is more air than it says: bleed the brake.
Less is the rig file's own air, whose compliance follows the pressure within each cycle (the
LTI model linearises it at the mean pressure, the paper's eq. 18); the improved model carries
it. Beside another effect named, the air a pair with entrained air fits is said too when it is
more than the rig file's and the pair explains a tenth of what the single leaves
(:func:`air_beside`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
import re

import numpy as np

from brake_hil.diagnosis.calibration import Calibration
from brake_hil.diagnosis.fitting import Fit
from brake_hil.physics.calibrated_values import VALUE_LABELS
from brake_hil.physics.parameters import chamber_volumes, derive_parameters, piston_area
from brake_hil.physics.rig import Rig

__all__ = [
    "AIR_BESIDE_CUT",
    "AIR_MORE_RATIO",
    "FLAG_SIGMAS",
    "air_beside",
    "air_finding",
    "air_in_words",
    "verdict_notes",
    "air_text",
    "outside",
    "rig_value_findings",
    "rig_values_text",
]

FLAG_SIGMAS = 2.0
"""A calibrated multiplier this many prior sigmas from 1 in log (and sure of it) is outside its
tolerance. On fresh contract-spanning nulls the seal's ``k_eh`` reached 1.5-1.7 sigmas (it
takes part of the uncalibrated piston area's error), so 1.5 named it on 2 of 8."""
POSTERIOR_SPAN = 2.0
"""Posterior sigmas the fitted value must keep clear of the one-sigma band."""
AIR_MORE_RATIO = 1.6
"""Air fraction over the rig file's above which the verdict says "more air than the rig file
says": between what fresh virtual recordings fitted (contract-spanning rigs, the rig's own air
following the pressure; the air named alone read as calibrated, :func:`for_verdict`):
0.69-1.39 times with the rig file's air, 1.70-3.13 times with 2.07 to 2.86 times it; 1.6 on
the bundled hose recording (its hose's compliance partly taken by the air, the reason the
calibrated air alone must also leave its band)."""
AIR_BESIDE_CUT = 1.1
"""Cut of what a single leaves by a pair with entrained air beside it, above which the air
that pair fits counts (:func:`air_beside`). Where nothing is beside the single a pair's cut
scatters about 1 (0.96-1.14 on fresh sets, the larger where the pair's air stays the rig
file's); this asks a tenth of the single's leftover explained, with more air than the rig file
says, both."""
ATMOSPHERE = 1.013e5
"""Absolute pressure of gauge zero (Pa), as the entrained_air candidate's."""
AIR_EFFECT = "entrained_air"
"""The air's effect: what a null with the rig file's own air may name, and the pair beside a
single that :func:`air_beside` reads."""
AIR_VALUES = ("entrained_air", "air_fraction", "bore_compliance")
"""The effect and the calibrated values an air finding is about (the trend's advice)."""
AS_RIG_FILE = (
    "the air's compliance follows the pressure as the rig file's air would; "
    "the improved model carries it"
)


def outside(multiplier: float, sigma: float, posterior: float) -> bool:
    """Whether a fitted multiplier lies outside the band its tolerance allows.

    More than ``FLAG_SIGMAS`` prior sigmas from 1 in log (the prior's own measure, the
    ``sigmas`` of ``verdict.rig_values``), and its interval of ``POSTERIOR_SPAN`` posterior
    sigmas clear of the one-sigma band.
    """
    level = abs(float(np.log(multiplier)))
    return level > FLAG_SIGMAS * sigma and level - POSTERIOR_SPAN * posterior > sigma


def rig_file_value(rig: Rig, name: str, mean_pressure: float) -> float:
    """The rig file's value (SI) of the quantity a calibration multiplier scales."""
    if name == "valve_resistance":
        return float(rig.model_overrides.get("R_v", rig.needle_valve_resistance))
    if name == "air_fraction":
        return rig.fluid.air_fraction
    if name == "hose_stiffness":
        return rig.hose.youngs_modulus
    if name == "bore_volume":
        return chamber_volumes(rig)[1]
    if name == "piston_area":
        return piston_area(rig)
    return float(getattr(derive_parameters(rig, mean_pressure), name))


def _keys_words(keys: tuple[str, ...]) -> str:
    shown = [k.replace("_", " ").replace(".", " ") for k in keys[:3]]
    return ", ".join(shown) + (" ..." if len(keys) > 3 else "")


def rig_value_findings(
    calibration: Calibration, multipliers: Mapping[str, float], mean_pressure: float
) -> list[dict[str, object]]:
    """``verdict.rig_values``: each calibrated quantity outside its tolerance (the air apart).

    Args:
        calibration: the calibration (prior and posterior sigmas, the keys setting each).
        multipliers: the fitted multipliers of the verdict's model (by name).
        mean_pressure: the recording's mean master-cylinder pressure (Pa).
    """
    found = []
    for name, m in multipliers.items():
        sigma = calibration.sigmas.get(name)
        if sigma is None or name == "air_fraction" or m <= 0:
            continue
        if not outside(m, sigma, calibration.uncertainty.get(name, sigma)):
            continue
        label = VALUE_LABELS.get(name)
        words = label.words if label is not None else name.replace("_", " ")
        keys = calibration.setters.get(name, ())
        nominal = rig_file_value(calibration.rig, name, mean_pressure)
        found.append(
            {
                "quantity": name,
                "keys": list(keys),
                "rig_file": nominal,
                "fitted": nominal * m,
                "ratio": round(m, 4),
                "sigmas": round(float(np.log(m)) / sigma, 2),
                "text": (
                    f"{words} at {m:.2f} of the rig file's, outside its +-{100 * sigma:.0f} %: "
                    f"check {_keys_words(keys)}"
                    + (f" ({label.cause})" if label is not None else "")
                ),
            }
        )
    return sorted(found, key=lambda f: -abs(float(f["sigmas"])))  # type: ignore[arg-type]


def rig_values_text(findings: list[dict[str, object]]) -> str:
    """``a rig value far outside its tolerance: check X`` (the findings' texts)."""
    return "a rig value far outside its tolerance: " + "; ".join(str(f["text"]) for f in findings)


def air_text(state: str, ratio: float) -> str:
    """The one sentence on the air, everywhere it is said (verdict, report, trend)."""
    if state == "more_than_rig_file":
        times = f"{ratio:.0f}" if ratio >= 10 else f"{ratio:.1f}"
        return f"more air than the rig file says ({times} times): bleed the brake"
    return AS_RIG_FILE


def air_finding(
    calibration: Calibration,
    multipliers: Mapping[str, float],
    air_share: float | None,
    mean_pressure: float,
    named: bool = False,
    shown: bool = False,
) -> dict[str, object] | None:
    """``verdict.air``, or None when the air needs no word.

    Args:
        calibration: the calibration (its rig file, the air's prior).
        multipliers: the fitted multipliers of the verdict's model.
        air_share: the entrained_air candidate's fitted share at gauge zero, when it is named.
        mean_pressure: the recording's mean master-cylinder pressure (Pa).
        named: the air is named: a word is due whatever the fraction.
        shown: a pair with entrained air beside the verdict's single cuts what it leaves
            (:meth:`.summary.Summary.air_beside_words`): beyond ``1 + tolerance`` times the
            rig file's the air is then said as more; else only beyond its band (:func:`outside`).
    """
    rig_fraction = calibration.rig.fluid.air_fraction
    m = multipliers.get("air_fraction", 1.0)
    sigma = calibration.sigmas.get("air_fraction")
    posterior = calibration.uncertainty.get("air_fraction", 0.0)
    tolerance = calibration.rig.tolerance("fluid.air_fraction")
    far = (
        sigma is not None
        and m > 1.0
        and (  # less air than the rig file's needs no word
            outside(m, sigma, posterior)
            or (
                shown
                and m > 1.0 + tolerance
                and float(np.log(m)) - POSTERIOR_SPAN * posterior > float(np.log(AIR_MORE_RATIO))
            )
        )
    )
    if air_share is None and not far and not named:
        return None
    fitted = rig_fraction * m
    if air_share is not None:  # j V p_atm / p_abs^2 equals j' V / p at the mean pressure
        absolute = mean_pressure + ATMOSPHERE
        fitted += air_share * ATMOSPHERE * mean_pressure / absolute**2
    ratio = fitted / max(rig_fraction, 1e-12)
    state = "more_than_rig_file" if ratio > AIR_MORE_RATIO else "as_rig_file"
    return {
        "rig_file_fraction": rig_fraction,
        "fitted_fraction": fitted,
        "ratio": round(ratio, 3),
        "tolerance": calibration.rig.tolerance("fluid.air_fraction"),
        "state": state,
        "text": air_text(state, ratio),
    }


def for_verdict(
    calibration: Calibration,
    parameters: Mapping[str, float],
    effects: tuple[str, ...],
    mean_pressure: float,
    ground: bool = False,
    air_shown: bool = False,
) -> tuple[list[dict[str, object]], dict[str, object] | None, str]:
    """``verdict.rig_values``, ``verdict.air`` and the explanation's added sentence.

    With ``entrained_air`` named alone the air is read as the calibrated LTI model fitted
    it: the rig file's own law (eq. 18, linearised at each window's mean pressure), the terms
    its fraction and tolerance are in. The candidate's isothermal share said at the mean
    pressure read 0.6-0.85 of the truth's air at two to three times the rig file's on fresh
    virtual recordings, often under ``AIR_MORE_RATIO``; the calibrated fraction 0.8-1.3 of it.
    Beside another effect the verdict's own model is read: the calibrated fraction alone
    would also carry that effect's compliance (a hose's).

    Args:
        calibration: the calibration.
        parameters: the verdict's fitted parameters (``calibration.NAME`` multipliers and the
            candidates' own, e.g. ``air_share``).
        effects: the verdict's effects.
        mean_pressure: the recording's mean master-cylinder pressure (Pa).
        ground: the rig values are the verdict's ground (it is named as one), not an "also".
        air_shown: a pair with entrained air beside the verdict's single cuts what it leaves
            (:func:`air_finding`'s ``shown``).
    """
    multipliers = {
        name: parameters.get(f"calibration.{name}", value)
        for name, value in calibration.multipliers.items()
    }
    rig_values = rig_value_findings(calibration, multipliers, mean_pressure)
    if effects == (AIR_EFFECT,):  # the air alone: in the rig file's own terms
        air = air_finding(calibration, calibration.multipliers, None, mean_pressure, True)
    else:
        share = parameters.get("air_share") if AIR_EFFECT in effects else None
        air = air_finding(calibration, multipliers, share, mean_pressure, shown=air_shown)
    words = []
    if rig_values and (effects == () or ground):
        text = rig_values_text(rig_values)
        words.append(f"{text[0].upper()}{text[1:]}.")
    elif rig_values:
        words.append("Also " + rig_values_text(rig_values) + ".")
    if air is not None:
        words.append(f"The air: {air['text']}.")
    return rig_values, air, " ".join(words)


def verdict_notes(verdict: Mapping[str, object]) -> list[str]:
    """The verdict lines' notes from a stored ``verdict`` (``rig value: ...``, ``air: ...``)."""
    notes = []
    values = verdict.get("rig_values")
    for item in values if isinstance(values, list) else []:
        if isinstance(item, dict) and isinstance(item.get("text"), str):
            notes.append(f"rig value: {item['text']}")
    air = verdict.get("air")
    if isinstance(air, dict) and isinstance(air.get("text"), str):
        notes.append(f"air: {air['text']}")
    return notes


def air_in_words(explanation: str) -> str | None:
    """The air sentence (:func:`air_text`) a verdict's explanation holds, or None."""
    more = re.search(r"The air: more air than the rig file says \(([0-9.]+) times\)", explanation)
    if more is not None:
        return air_text("more_than_rig_file", float(more.group(1)))
    return AS_RIG_FILE if f"The air: {AS_RIG_FILE}" in explanation else None


def air_beside(
    calibration: Calibration,
    singles: Sequence[Fit],
    pairs: Sequence[Fit],
    mean_pressure: float,
) -> dict[str, tuple[float, float]]:
    """Each single's pair with entrained air: the air it fits over the rig file's, and its cut.

    The air is :func:`air_finding`'s (the calibrated fraction and the candidate's share at
    the mean pressure) from the pair's own values; the cut is how many times the pair cuts
    the held-out error the single leaves. Both past their bars (``AIR_MORE_RATIO``,
    ``AIR_BESIDE_CUT``) say more air than the rig file says beside the single, whatever the
    posterior makes of one more parameter (:meth:`.summary.Summary.doubt`).
    """
    found = {}
    for single in singles:
        name = single.effects[0]
        pair = next((p for p in pairs if set(p.effects) == {name, AIR_EFFECT}), None)
        if pair is None or name == AIR_EFFECT:
            continue
        values = pair.parameters()
        multipliers = {
            key: values.get(f"calibration.{key}", value)
            for key, value in calibration.multipliers.items()
        }
        air = air_finding(calibration, multipliers, values.get("air_share"), mean_pressure)
        if air is not None:
            cut = single.held_out_cost / max(pair.held_out_cost, 1e-300)
            found[name] = (float(air["ratio"]), float(cut))  # type: ignore[arg-type]
    return found
