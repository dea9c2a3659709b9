"""Concealed-effect benchmark: labelled virtual-rig cases for scoring a diagnosis blind.

Here the cases are described (:func:`plan_cases`, :func:`select_cases`), one is simulated and
written (:func:`make_case`: ``DIR/cases/NNN/recording/``, a rosbag2 MCAP directory, and
``DIR/cases/NNN/rig.yaml``, the *nominal* rig the engineer believes), and the labels are
written apart from them (:func:`write_labels`: ``DIR/labels.json``, which a diagnosis run on
``DIR/cases`` never reads); :func:`brake_hil.app.cases.generate_cases` runs
:func:`make_case` over the described cases in parallel. A case is:

* ``null``: a parameter error only (truth differs from nominal within the rig tolerances),
  alternately on a degassed rig (``fluid.air_fraction`` 1e-6 in the rig file and the truth)
  and with the rig file's own air, isothermal at each chamber's instantaneous pressure
  (:data:`~brake_hil.virtual_rig.plant.RIG_AIR_LAWS`: the rig itself, not an effect), labelled
  ``"air": "degassed"`` or ``"rig_file"``;
* ``single``: one effect at a ``subtle`` (strength 0.15-0.35) or ``strong`` (0.7-1.0)
  strength, on top of a parameter error;
* ``pair``: two different effects, each subtle or strong;
* ``unexplained``: physics outside the diagnosis's library (``OUT_OF_LIBRARY``: a transducer
  gain that changes with its reading), subtle or strong, labelled ``["unexplained"]``;
* ``out_of_tolerance`` (``contract`` span only): no effect, one rig value 1 to 2 tolerances
  off (:func:`~brake_hil.virtual_rig.draws.draw_out_of_tolerance`), the rest within,
  labelled with its ``key`` and ``ratio`` (truth / rig file);
* ``more_air`` (``contract`` span only): no effect, the rig's own air (instantaneous law) at
  2 to 3 times the rig file's fraction, labelled with its ``ratio``.

Two families of truth laws make the cases: ``a`` (the default) draws each effect's law from
:data:`~brake_hil.virtual_rig.effects.EFFECTS` and its out-of-library cases from
``OUT_OF_LIBRARY``; ``b`` draws the structurally different laws of
:data:`~brake_hil.virtual_rig.family_b.EFFECTS_B` (the same effects, so the same labels) and
the out-of-library effects of :data:`~brake_hil.virtual_rig.family_b.OUTSIDE_B`, from
streams of its own, and acquires every case through its own measurement chain
(:class:`~brake_hil.virtual_rig.family_b.MeasurementChainB`, not an effect). A diagnosis
tuned on one family is judged on the other.

:func:`plan_cases` fixes the schedule so that the first cases already cover every kind: null
cases, every effect both subtle and strong, and pairs. Every draw comes from
``numpy.random.default_rng([seed, case number])``, so a case does not depend on how many
others are generated or in which process (family b: ``default_rng([seed, case number, 2])``).

Parameter errors (:mod:`~brake_hil.virtual_rig.draws`): by default (``span="contract"``)
every toleranced value of the rig file is drawn uniformly within its tolerance (the air and
the seal values within 10 %); ``span="seed"`` replays the stored sets' draw (13 keys, a
normal of half a tolerance clipped at one) and their schedule, without the new kinds.
Per round of the ``contract`` schedule, one ``out_of_tolerance`` and one ``more_air`` case
follow the 26 (family a) of the ``seed`` schedule: 2 of 28, 7 % each.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
import dataclasses
from dataclasses import dataclass, field
import json
from pathlib import Path
from typing import Any

import numpy as np

from brake_hil import __version__
from brake_hil.physics.excitation import SEED_MAX_PRESSURES
from brake_hil.physics.rig import Rig, rig_from_mapping
from brake_hil.virtual_rig.bag import write_run
from brake_hil.virtual_rig.draws import (
    MORE_AIR_RATIOS,
    SPANS,
    draw_out_of_tolerance,
    draw_parameter_errors,
)
from brake_hil.virtual_rig.effects import (
    EFFECTS,
    OUT_OF_LIBRARY,
    Effect,
    EffectError,
    effect_class,
)
from brake_hil.virtual_rig.excitation import (
    Excitation,
    air_driven,
    named_excitation,
    seed_pulsing,
    solenoid_pulsing,
)
from brake_hil.virtual_rig.family_b import (
    EFFECTS_B,
    FAMILY_B,
    MeasurementChainB,
    is_family_b_law,
    outside_names,
)
from brake_hil.virtual_rig.family_c import EFFECTS_C, FAMILY_C, OUTSIDE_C, MeasurementChainC
from brake_hil.virtual_rig.rig_yaml import rig_to_mapping, rig_with_values, write_rig
from brake_hil.virtual_rig.simulator import simulate_rig

FAMILIES = ("a", FAMILY_B, FAMILY_C)
"""The families of truth laws a case can be made of (``a``: the registered laws; ``c``: the
laws written from the physics alone, :mod:`~brake_hil.virtual_rig.family_c`)."""
_FAMILY_STREAM = {"a": (), FAMILY_B: (2,), FAMILY_C: (3,)}
"""What each family appends to a case's seed sequence (family a's draws are the original)."""

SUBTLE_STRENGTHS = (0.15, 0.35)
STRONG_STRENGTHS = (0.7, 1.0)

_PHYSICS_MD_RIG: dict[str, Any] = {
    "rig": {
        "name": "nominal one-washer rig",
        "washers": 1,
        "washer_thickness": 1.5e-3,
        "pistons": {"count": 2, "diameter": 0.040, "mass": 0.2},
        "bore": {"area_ratio": 1.15, "length": 0.012},
        "caliper": {"mass": 2.5, "stiffness": 4.0e7, "transducer_distance": 0.10},
        "block": {"stiffness": 1.5e9},
        "seal": {
            "youngs_modulus": 9.2e6,
            "poisson_ratio": 0.49,
            "squeeze": 0.15,
            "width": 3.0e-3,
            "shear_length": 1.0e-4,
            "friction_coefficient": 0.30,
            "loss_factor": 0.10,
        },
        "bore_friction_coefficient": 0.20,
        "fluid": {
            "density": 1050.0,
            "viscosity": 0.008,
            "bulk_modulus": 1.6e9,
            "air_fraction": 0.001,
        },
        "hard_pipe": {"length": 1.5, "diameter": 3.2e-3, "wall": 0.7e-3, "youngs_modulus": 2.0e11},
        "hose": {"length": 0.6, "diameter": 3.2e-3, "wall": 3.5e-3, "youngs_modulus": 1.0e9},
        "needle_valve": {"resistance": 3.2e10},
        "excitation_hz": 5.0,
    }
}
RESTRICTED_VALVE_RESISTANCE = 1.3e11
"""Linearised resistance of the seed's restricted needle valve (Pa s/m^3, physics.md)."""


def nominal_rigs() -> dict[str, Rig]:
    """physics.md's default parameter set: one and five washers, valve open and restricted."""
    base = rig_from_mapping(_PHYSICS_MD_RIG, source="physics.md default set")
    rigs = {}
    for washers in (1, 5):
        for valve, resistance in (("open", 3.2e10), ("restricted", RESTRICTED_VALVE_RESISTANCE)):
            key = f"{'one' if washers == 1 else 'five'}_washer_{valve}"
            name = f"nominal {'one' if washers == 1 else 'five'}-washer rig, valve {valve}"
            document = rig_to_mapping(base)
            document["rig"]["washers"] = washers
            document["rig"]["needle_valve"]["resistance"] = resistance
            document["rig"]["name"] = name
            rigs[key] = rig_from_mapping(document, source=f"physics.md default set, {key}")
    return rigs


@dataclass(frozen=True)
class CaseSpec:
    """What one case holds (the label) before it is simulated."""

    number: int
    kind: str  # null, single, pair, unexplained, out_of_tolerance or more_air
    strength_class: str  # none (null), subtle, strong, or mixed (a pair of both)
    effects: tuple[Effect, ...]
    nominal_key: str  # which of the nominal rigs
    parameter_errors: dict[str, float] = field(default_factory=dict)  # truth / nominal - 1
    air_driven: bool = False
    noise_seed: int = 0
    family: str = "a"  # the family of truth laws (FAMILIES)
    span: str = "contract"  # how the parameter errors were drawn (draws.SPANS)
    air: str = ""  # null: degassed or rig_file; more_air: more; else the rig file's
    rig_air: str = "linearised"  # the law of the rig's own air (plant.RIG_AIR_LAWS)
    off_key: str = ""  # out_of_tolerance: the rig value far off

    @property
    def case_id(self) -> str:
        """Folder name of the case (``000``, ``001``, ...)."""
        return f"{self.number:03d}"


@dataclass(frozen=True)
class CaseDrive:
    """How every case of a set is driven: the seed's pulsing unless told otherwise.

    Another frequency or other pressures test the diagnosis on an excitation it was not
    tuned on (an independent simulator's rig may pulse at 8 Hz, to 2.5 MPa).
    """

    excitation_hz: float | None = None  # Hz, the pulsing (None: the nominal rig's, 5 Hz)
    max_pressures: tuple[float, ...] = SEED_MAX_PRESSURES  # Pa, one steady segment each
    excitation: str = "pulsing"  # one of EXCITATION_KINDS (pulsing: the seed's)

    def nominal(self, rig: Rig) -> Rig:
        """The nominal rig as the case's ``rig.yaml`` describes it: pulsing at this drive's."""
        if self.excitation_hz is None:
            return rig
        return dataclasses.replace(rig, excitation_hz=self.excitation_hz)

    def as_dict(self, rig_hz: float) -> dict[str, Any]:
        """The drive for ``labels.json`` (``rig_hz``: the nominal rig's pulsing, Hz)."""
        result: dict[str, Any] = {
            "excitation_hz": rig_hz if self.excitation_hz is None else self.excitation_hz,
            "max_pressures_mpa": [round(p / 1e6, 6) for p in self.max_pressures],
        }
        if self.excitation != "pulsing":  # the seed's pulsing: the labels as they always were
            result["excitation"] = self.excitation
        return result


SEED_DRIVE = CaseDrive()
"""The seed's drive: the nominal rig's 5 Hz pulsing to 1.38, 2.07 and 2.76 MPa."""


def _check_family(family: str) -> None:
    if family not in FAMILIES:
        raise EffectError(
            f"unknown family of truth laws {family!r} (known: {', '.join(FAMILIES)})"
        )


def _library(family: str) -> tuple[list[str], list[str]]:
    """The family's library effects and out-of-library effects, by name.

    Family a's out-of-library effects leave out family b's (registered once family b is used).
    """
    if family == FAMILY_B:
        return list(EFFECTS_B), list(outside_names())
    if family == FAMILY_C:
        return list(EFFECTS_C), list(OUTSIDE_C)
    outside = [name for name, cls in OUT_OF_LIBRARY.items() if not is_family_b_law(cls)]
    return list(EFFECTS), outside


def _schedule(
    count: int, seed: int, family: str = "a", extra: tuple[str, ...] = ()
) -> Iterator[tuple[str, tuple[str, ...], tuple[str, ...]]]:
    """(kind, effect names, strength classes) for each case, covering every kind early.

    Per round of ``2 * E + 2 + 4 + 2`` cases (``E`` effects): two null cases, each effect
    once subtle and once strong (subtle first for half of them), four pairs, and one subtle
    and one strong out-of-library case; then one case of each ``extra`` kind (no effect).
    """
    names, outside = _library(family)
    rng = np.random.default_rng([seed, 1_000_003, *_FAMILY_STREAM[family]])
    produced = 0
    while produced < count:
        order = [names[i] for i in rng.permutation(len(names))]
        first = [
            ("single", (name,), ("subtle" if i % 2 else "strong",)) for i, name in enumerate(order)
        ]
        second = [
            ("single", (name,), ("strong" if i % 2 else "subtle",)) for i, name in enumerate(order)
        ]
        pairs = []
        for _ in range(4):
            a, b = rng.choice(len(names), size=2, replace=False)
            classes = tuple(str(c) for c in rng.choice(["subtle", "strong"], size=2))
            pairs.append(("pair", (names[int(a)], names[int(b)]), classes))
        round_ = [("null", (), ()), *first, pairs[0], pairs[1], ("null", (), ()), *second]
        round_ += pairs[2:]
        round_ += [
            ("unexplained", (outside[int(rng.integers(len(outside)))],), (c,))
            for c in ("subtle", "strong")
        ]
        round_ += [(kind, (), ()) for kind in extra]
        for item in round_:
            if produced == count:
                return
            produced += 1
            yield item


def _draw_effect(
    name: str, strength_class: str, rng: np.random.Generator, family: str = "a"
) -> Effect:
    """The effect ``name`` of ``family`` at a strength of its class, drawing its own parameters.

    Family b's library effects are its own laws; out-of-library effects come from the registry.
    """
    low, high = SUBTLE_STRENGTHS if strength_class == "subtle" else STRONG_STRENGTHS
    strength = float(np.round(rng.uniform(low, high), 3))
    if family == FAMILY_B and name in EFFECTS_B:
        return EFFECTS_B[name].draw(rng, strength)
    if family == FAMILY_C:
        return {**EFFECTS_C, **OUTSIDE_C}[name].draw(rng, strength)
    return effect_class(name).draw(rng, strength)


def truth_rig(nominal: Rig, errors: dict[str, float], name: str) -> Rig:
    """The nominal rig with each dotted value multiplied by ``1 + error``."""
    document = rig_to_mapping(nominal)["rig"]
    values = {}
    for key, error in errors.items():
        node: Any = document
        for part in key.split("."):
            node = node[part]
        values[key] = float(node) * (1.0 + error)
    return rig_with_values(nominal, values, name=name)


NEW_KINDS = ("out_of_tolerance", "more_air")
"""The kinds only the ``contract`` span's schedule holds (one each per round)."""
KINDS = ("null", "single", "pair", "unexplained", *NEW_KINDS)
"""Every kind of case (see the module docstring)."""
DEGASSED_AIR_FRACTION = 1e-6
"""``fluid.air_fraction`` of a degassed null case, in its rig file and its truth."""


def _check_span(span: str) -> None:
    if span not in SPANS:
        raise EffectError(f"unknown span of parameter errors {span!r} (known: {', '.join(SPANS)})")


def _contract_fields(
    kind: str, nominal: Rig, rng: np.random.Generator, errors: dict[str, float], nulls: int
) -> dict[str, Any]:
    """What the ``contract`` span adds to a case: its air, air law and far value, if any.

    Drawn after every draw the ``seed`` span makes, so those stay as they were.
    """
    if kind == "null":
        return {"air": ("degassed", "rig_file")[nulls % 2], "rig_air": "instantaneous"}
    if kind == "out_of_tolerance":
        key, error = draw_out_of_tolerance(nominal, rng)
        errors[key] = error
        return {"air": "rig_file", "rig_air": "instantaneous", "off_key": key}
    if kind == "more_air":
        ratio = float(np.round(rng.uniform(*MORE_AIR_RATIOS), 4))
        errors["fluid.air_fraction"] = ratio - 1.0
        return {"air": "more", "rig_air": "instantaneous"}
    return {}


def plan_cases(
    count: int,
    seed: int,
    *,
    nominal_keys: Sequence[str] = ("one_washer_open", "one_washer_restricted", "five_washer_open"),
    error_scale: float = 1.0,
    air_driven_share: float = 0.25,
    family: str = "a",
    span: str = "contract",
) -> list[CaseSpec]:
    """The labelled cases of ``family``'s truth laws, before simulation (see the module docstring).

    ``span`` (:data:`~brake_hil.virtual_rig.draws.SPANS`): ``contract`` draws every
    toleranced value and mixes in the new kinds; ``seed`` replays the stored sets.

    Raises:
        EffectError: an unknown family or span.
    """
    _check_family(family)
    _check_span(span)
    rigs = nominal_rigs()
    extra = NEW_KINDS if span == "contract" else ()
    specs: list[CaseSpec] = []
    for number, (kind, names, classes) in enumerate(_schedule(count, seed, family, extra)):
        rng = np.random.default_rng([seed, number, *_FAMILY_STREAM[family]])
        nominal_key = str(rng.choice(list(nominal_keys)))
        effects = tuple(_draw_effect(n, c, rng, family) for n, c in zip(names, classes))
        strength_class = "none" if not classes else classes[0]
        if len(set(classes)) > 1:
            strength_class = "mixed"
        errors = draw_parameter_errors(rigs[nominal_key], rng, error_scale, span)
        air_driven = bool(rng.uniform() < air_driven_share)
        noise_seed = int(rng.integers(0, 2**31 - 1))
        fields: dict[str, Any] = {}
        if span == "contract":
            nulls = sum(spec.kind == "null" for spec in specs)
            fields = _contract_fields(kind, rigs[nominal_key], rng, errors, nulls)
        specs.append(
            CaseSpec(
                number=number,
                kind=kind,
                strength_class=strength_class,
                effects=effects,
                nominal_key=nominal_key,
                parameter_errors=errors,
                air_driven=air_driven,
                noise_seed=noise_seed,
                family=family,
                span=span,
                **fields,
            )
        )
    return specs


def select_cases(
    count: int,
    seed: int,
    kinds: Sequence[str] = (),
    *,
    error_scale: float = 1.0,
    family: str = "a",
    span: str = "contract",
) -> list[CaseSpec]:
    """The first ``count`` cases of the schedule whose kind is one of ``kinds`` (all: empty).

    A kept case is the very case of that number in ``family``'s full schedule.

    Raises:
        EffectError: an unknown family or span, or a kind the span's schedule never holds.
    """
    if missing := [k for k in kinds if k in NEW_KINDS and span != "contract"]:
        raise EffectError(f"kind {missing[0]} is made only with the contract span")
    if unknown := [k for k in kinds if k not in KINDS]:
        raise EffectError(f"unknown kind {unknown[0]!r} (known: {', '.join(KINDS)})")
    planned = count
    specs = plan_cases(planned, seed, error_scale=error_scale, family=family, span=span)
    if not kinds:
        return specs
    while sum(spec.kind in kinds for spec in specs) < count:
        planned *= 2
        specs = plan_cases(planned, seed, error_scale=error_scale, family=family, span=span)
    return [spec for spec in specs if spec.kind in kinds][:count]


def case_excitation(
    spec: CaseSpec,
    truth: Rig,
    pulsing_s: float,
    max_pressures: Sequence[float] = SEED_MAX_PRESSURES,
    kind: str = "pulsing",
) -> Excitation:
    """Pulsing at ``truth``'s frequency, solenoid-driven or as ``p_i``; or another ``kind``.

    One segment per maximum pressure (Pa): the seed's 1.38, 2.07, 2.76 MPa by default.
    Another of :data:`~brake_hil.virtual_rig.excitation.EXCITATION_KINDS` is its ``p_i``,
    or the air pressure of it (:func:`~brake_hil.virtual_rig.excitation.air_driven`).
    """
    if kind != "pulsing":
        drive = named_excitation(
            kind, max_pressures, pulsing_s=pulsing_s, pulsing_hz=truth.excitation_hz
        )
        return air_driven(truth, drive) if spec.air_driven else drive
    if spec.air_driven:
        return solenoid_pulsing(
            truth, max_pressures, pulsing_s=pulsing_s, pulsing_hz=truth.excitation_hz
        )
    return seed_pulsing(max_pressures, pulsing_s=pulsing_s, pulsing_hz=truth.excitation_hz)


def measurement_chain(spec: CaseSpec) -> tuple[Effect, ...]:
    """The case's measurement chain beyond the seed's DAQ: family b's or c's, none for a.

    Installed after the effects (their laws act first on a channel), never labelled as one.
    """
    if spec.family == FAMILY_B:
        return (MeasurementChainB(seed=spec.noise_seed),)
    if spec.family == FAMILY_C:
        return (MeasurementChainC(seed=spec.noise_seed),)
    return ()


def _contract_label(spec: CaseSpec) -> dict[str, Any]:
    """The label's span, air law, and the new kinds' ``air``, ``key`` and ``ratio``."""
    result: dict[str, Any] = {"span": spec.span, "rig_air": spec.rig_air}
    if spec.air:
        result["air"] = spec.air
    if spec.kind == "out_of_tolerance":
        result["key"] = spec.off_key
        result["ratio"] = round(1.0 + spec.parameter_errors[spec.off_key], 6)
    if spec.kind == "more_air":
        result["ratio"] = round(1.0 + spec.parameter_errors["fluid.air_fraction"], 6)
    return result


def label(spec: CaseSpec, truth: Rig, excitation: Excitation) -> dict[str, Any]:
    """The JSON label of one case."""
    result = {
        "family": spec.family,
        "kind": spec.kind,
        "strength_class": spec.strength_class,
        "expected_effects": (
            ["unexplained"]
            if spec.kind == "unexplained"
            else sorted(effect.name for effect in spec.effects)
        ),
        "effects": [{"name": e.name, "parameters": e.values()} for e in spec.effects],
        "nominal_rig": spec.nominal_key,
        "parameter_errors": spec.parameter_errors,
        "truth_rig": rig_to_mapping(truth),
        "excitation": excitation.label,
        "air_driven": spec.air_driven,
        "noise_seed": spec.noise_seed,
    }
    result.update(_contract_label(spec))
    if chain := measurement_chain(spec):
        result["measurement_chain"] = [{"name": c.name, "parameters": c.values()} for c in chain]
    return result


def case_nominal(spec: CaseSpec, drive: CaseDrive = SEED_DRIVE) -> Rig:
    """The rig file of the case: the nominal rig at the drive's pulsing, degassed if so."""
    nominal = drive.nominal(nominal_rigs()[spec.nominal_key])
    if spec.air == "degassed":
        degassed = {"fluid.air_fraction": DEGASSED_AIR_FRACTION}
        return rig_with_values(nominal, degassed, name=f"{nominal.name}, degassed")
    return nominal


def make_case(
    spec: CaseSpec, cases_dir: Path, pulsing_s: float, drive: CaseDrive = SEED_DRIVE
) -> dict[str, Any]:
    """Simulate and write one case; return its label."""
    nominal = case_nominal(spec, drive)
    truth = truth_rig(nominal, spec.parameter_errors, f"truth of case {spec.case_id}")
    excitation = case_excitation(spec, truth, pulsing_s, drive.max_pressures, drive.excitation)
    effects = (*spec.effects, *measurement_chain(spec))
    run = simulate_rig(truth, effects, excitation, rig_air=spec.rig_air, seed=spec.noise_seed)
    folder = cases_dir / spec.case_id
    folder.mkdir(parents=True, exist_ok=False)
    write_run(run, folder / "recording")
    write_rig(nominal, folder / "rig.yaml", "The rig as the test engineer describes it.")
    result = label(spec, truth, excitation)
    if drive.excitation != "pulsing":
        result["excitation_kind"] = drive.excitation
    result["simulation_seconds"] = round(run.solver.seconds, 3)
    return result


def write_labels(
    out: Path,
    labels: Mapping[str, dict[str, Any]],
    *,
    count: int,
    seed: int,
    pulsing_s: float,
    error_scale: float,
    kinds: Sequence[str],
    family: str = "a",
    drive: CaseDrive = SEED_DRIVE,
    span: str = "contract",
) -> Path:
    """Write ``out/labels.json``: how the cases were made and each case's label.

    Args:
        out: the benchmark's directory (``cases/`` beside the file).
        labels: :func:`make_case`'s label of each case, by case id.
        count: number of cases asked for.
        seed: seed of every draw.
        pulsing_s: seconds of 5 Hz pulsing per maximum pressure.
        error_scale: the parameter errors' scale of the rig tolerances.
        kinds: the kinds kept (empty: every kind).
        family: the family of truth laws the cases were made of.
        drive: how the cases were driven (pulsing frequency, maximum pressures).
        span: how the parameter errors were drawn (``contract`` or ``seed``).

    Returns:
        The path of ``labels.json``.
    """
    document = {
        "generator": {
            "tool": f"brake_hil {__version__} virtual rig",
            "count": count,
            "seed": seed,
            "pulsing_s": pulsing_s,
            "error_scale": error_scale,
            "kinds": list(kinds),
            "family": family,
            "span": span,
            **drive.as_dict(next(iter(nominal_rigs().values())).excitation_hz),
            "layout": "cases/NNN/recording (rosbag2 MCAP) + cases/NNN/rig.yaml (nominal)",
        },
        "cases": dict(sorted(labels.items())),
    }
    path = out / "labels.json"
    path.write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")
    return path
