"""A tenth effect is one catalogue entry, a truth law of each family and a candidate.

A throw-away effect, a zero offset of the bore-pressure transducer, is registered at run time
with exactly what CONTRIBUTING.md lists: its catalogue entry (which carries the rig check,
the trend's words and cause), a family-a truth law, a family-b truth law and a candidate, with
no edit anywhere else. Both families' virtual rigs then record it (family b's case schedule
draws it), the diagnosis, blind, names it and models it, and the report's rig check and the
trend's advice for it come out of the entry.
"""

from __future__ import annotations

from collections.abc import Iterator
import dataclasses
import html
from pathlib import Path

import numpy as np
import pytest

from brake_hil.diagnosis.candidates import (
    CANDIDATES,
    Candidate,
    register_candidate,
    unregister_candidate,
)
from brake_hil.diagnosis.candidates.base import CandidateParameter, Context, Draft
from brake_hil.diagnosis.dataset import ZERO_STABILITY
from brake_hil.diagnosis.diagnose import Diagnosis, diagnose
from brake_hil.diagnosis.engine import Term
from brake_hil.physics import catalogue
from brake_hil.physics.catalogue import EffectEntry, Quantity
from brake_hil.physics.measurement import SENSORS
from brake_hil.physics.rig import Rig
from brake_hil.report.diagnosis_report import RIG_CHECKS, write_report
from brake_hil.results.trend import ADVICE, Advice
from brake_hil.types import FloatArray
from brake_hil.virtual_rig.cases import measurement_chain, plan_cases
from brake_hil.virtual_rig.effects import (
    STRENGTH,
    Effect,
    Parameter,
    parse_effect,
    register_effect,
    unregister_effect,
)
from brake_hil.virtual_rig.excitation import seed_pulsing
from brake_hil.virtual_rig.family_b import (
    EFFECTS_B,
    FamilyBEffect,
    register_effect_b,
    unregister_effect_b,
)
from brake_hil.virtual_rig.laws import LtiPlant, TruthLaw
from brake_hil.virtual_rig.simulator import simulate_rig

# --------------------------------------------------------------------- 1. the catalogue entry

ZERO_OFFSET = EffectEntry(
    name="bore_sensor_offset",
    title="the bore-pressure transducer reads a zero offset",
    physics=(
        "A strain-gauge pressure transducer whose zero has shifted (mounting torque, "
        "temperature) adds a constant to every reading of p_b."
    ),
    source="measurement chain (not in the seed)",
    signature="p_b off the prediction by a constant in every segment; F_k and x_c right",
    channels=("p_b",),
    quantities=(Quantity("p_0", "Pa", "zero offset of the p_b transducer"),),
    rig_check="the p_b transducer: its zero at rest, its mounting torque",
    label="bore-sensor offset",
    cause="re-zero the p_b transducer",
)

# --------------------------------------------------------------------- 2. the truth laws


@dataclasses.dataclass(frozen=True)
class _OffsetLaw(TruthLaw):
    offset: float  # Pa
    settling_time: float  # s: the zero drifts in after power-up (richer than the candidate)

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        if channel != "p_b":
            return values
        return values + self.offset * (1.0 - np.exp(-(time - time[0]) / self.settling_time))


@dataclasses.dataclass(frozen=True)
class _BoreSensorOffset(Effect):
    """The bore-pressure transducer reads a zero offset that settles in after power-up.
    Source: the measurement chain (not in the seed)."""

    strength: float = 1.0
    offset: float = 4.0e4
    settling_time: float = 0.05

    entry = ZERO_OFFSET
    parameters = (
        STRENGTH,
        Parameter("offset", "Pa", -2.0e5, 2.0e5, "zero offset at strength 1"),
        Parameter("settling_time", "s", 1.0e-3, 1.0, "time constant of the zero's settling"),
    )
    diagnosis_model = "a constant offset (the simulator's zero settles in exponentially)"

    def law(self, plant: LtiPlant) -> _OffsetLaw:
        del plant
        return _OffsetLaw(self.strength * self.offset, self.settling_time)


@dataclasses.dataclass(frozen=True)
class _RampedOffsetLaw(TruthLaw):
    offset: float  # Pa
    ramp_time: float  # s: the zero ramps in linearly (family b: another law of the same effect)

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        if channel != "p_b":
            return values
        return values + self.offset * np.clip((time - time[0]) / self.ramp_time, 0.0, 1.0)


@dataclasses.dataclass(frozen=True)
class _BoreSensorOffsetB(FamilyBEffect, effect="bore_sensor_offset"):
    """The bore-pressure transducer reads a zero offset that ramps in after power-up.
    Source: the measurement chain (not in the seed)."""

    strength: float = 1.0
    offset: float = 4.0e4
    ramp_time: float = 0.1

    parameters = (
        STRENGTH,
        Parameter("offset", "Pa", -2.0e5, 2.0e5, "zero offset at strength 1"),
        Parameter("ramp_time", "s", 1.0e-3, 1.0, "time the zero takes to ramp in"),
    )
    diagnosis_model = "a constant offset (the simulator's zero ramps in linearly)"

    def law(self, plant: LtiPlant) -> _RampedOffsetLaw:
        del plant
        return _RampedOffsetLaw(self.strength * self.offset, self.ramp_time)


# --------------------------------------------------------------------- 3. the candidate


@dataclasses.dataclass(frozen=True)
class _ChannelOffset(Term):
    offset: FloatArray  # (B,) Pa on p_b

    def transform(self, outputs: FloatArray, sample_time: float) -> FloatArray:
        outputs[:, 0, :] += self.offset[:, np.newaxis]
        return outputs


class _OffsetCandidate(Candidate):
    """Bore-sensor offset: the p_b transducer adds a constant to every reading."""

    entry = ZERO_OFFSET
    parameters = (CandidateParameter("offset_p_b", "Pa", -2.0e5, 2.0e5, 0.0),)

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        draft.add(_ChannelOffset(theta[:, 0].copy()))


# --------------------------------------------------------------------- the test


@pytest.fixture
def tenth_effect() -> Iterator[None]:
    """Exactly what CONTRIBUTING.md lists: the entry, a law of each family, the candidate."""
    catalogue.register(ZERO_OFFSET)
    try:
        register_effect(_BoreSensorOffset)
        register_effect_b(_BoreSensorOffsetB)
        register_candidate(_OffsetCandidate())
        yield
    finally:
        unregister_candidate(ZERO_OFFSET.name)
        unregister_effect_b(ZERO_OFFSET.name)
        unregister_effect(ZERO_OFFSET.name)
        catalogue.unregister(ZERO_OFFSET.name)


def _diagnosed_offset(effects: list[Effect], rig: Rig) -> Diagnosis:
    """The blind diagnosis of a run of the rig with ``effects`` (a small parameter error)."""
    truth = dataclasses.replace(
        rig, caliper_stiffness=rig.caliper_stiffness * 1.05
    )  # a parameter error within tolerance, as every benchmark case has
    run = simulate_rig(truth, effects, seed_pulsing((1.38e6, 2.76e6), pulsing_s=3.0), seed=3)
    assert abs(float(np.median(run.measured["p_b"] - run.bore_pressure)) - 4.0e4) < 2.0e3
    result = diagnose(run.as_recording(), rig)
    assert result.effects == ("bore_sensor_offset",), result.explanation
    fitted = result.improved.parameters()["offset_p_b"]
    # p_b is read on the measured zero within the transducers' zero stability: an offset is
    # known only to that bound (every value within it fits alike), the rest is the candidate's
    stability = ZERO_STABILITY * (SENSORS["p_b"].high - SENSORS["p_b"].low)
    assert abs(fitted - 4.0e4) < 4.0e3 + stability, fitted
    return result


def test_a_tenth_effect_runs_through_the_virtual_rig_and_the_diagnosis(
    tenth_effect: None, default_rig: Rig, tmp_path: Path
) -> None:
    assert [c.name for c in CANDIDATES][-1] == "bore_sensor_offset"
    result = _diagnosed_offset([parse_effect("bore_sensor_offset=1.0")], default_rig)
    baseline, improved = result.baseline.held_out_rms, result.improved.held_out_rms
    assert baseline["p_b"] > 5 * improved["p_b"], (baseline, improved)
    assert result.confidence > 0.5
    hypotheses = result.as_dict()["hypotheses"]
    assert isinstance(hypotheses, list) and hypotheses[0]["effect"] == "bore_sensor_offset"

    # the report's rig check and the trend's advice come out of the entry
    assert RIG_CHECKS["bore_sensor_offset"] == ZERO_OFFSET.rig_check
    page = write_report(result, tmp_path / "report").read_text(encoding="utf-8")
    assert html.escape(ZERO_OFFSET.rig_check) in page
    assert ADVICE["bore_sensor_offset"] == Advice(ZERO_OFFSET.label, ZERO_OFFSET.cause)


def test_family_b_draws_the_tenth_effect_and_the_diagnosis_names_it(
    tenth_effect: None, default_rig: Rig
) -> None:
    assert list(EFFECTS_B)[-1] == "bore_sensor_offset"
    singles = [
        spec
        for spec in plan_cases(28, seed=5, family="b")
        if spec.kind == "single" and spec.effects[0].name == "bore_sensor_offset"
    ]
    assert len(singles) == 2 and all(type(s.effects[0]) is _BoreSensorOffsetB for s in singles)
    chain = list(measurement_chain(singles[0]))
    _diagnosed_offset([_BoreSensorOffsetB(1.0), *chain], default_rig)


def test_after_the_test_the_tenth_effect_is_gone() -> None:
    assert "bore_sensor_offset" not in catalogue.CATALOGUE
    assert "bore_sensor_offset" not in [c.name for c in CANDIDATES]
    assert "bore_sensor_offset" not in EFFECTS_B
    assert "bore_sensor_offset" not in RIG_CHECKS and "bore_sensor_offset" not in ADVICE


# --------------------------------------------------------------------- a model that diverges


@dataclasses.dataclass(frozen=True)
class _Diverging(Term):
    def transform(self, outputs: FloatArray, sample_time: float) -> FloatArray:
        return outputs * np.inf


class _DivergingCandidate(Candidate):
    """A candidate whose simulation is never finite (an unstable term, as an explicit drop
    with a large coefficient can be)."""

    entry = ZERO_OFFSET
    parameters = (CandidateParameter("gain", "-", 0.0, 1.0, 0.5),)

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        draft.add(_Diverging())


@pytest.fixture
def diverging_candidate() -> Iterator[None]:
    catalogue.register(ZERO_OFFSET)
    try:
        register_candidate(_DivergingCandidate())
        yield
    finally:
        unregister_candidate(ZERO_OFFSET.name)
        catalogue.unregister(ZERO_OFFSET.name)


def test_a_hypothesis_that_cannot_be_simulated_is_left_out_not_a_crash(
    diverging_candidate: None, default_rig: Rig
) -> None:
    run = simulate_rig(
        default_rig, [parse_effect("sensor_delay=1.0")], seed_pulsing((1.38e6,), pulsing_s=3.0)
    )
    said: list[str] = []
    result = diagnose(run.as_recording(), default_rig, progress=said.append)
    assert result.unfitted == ("bore_sensor_offset",)
    assert any("not finite where its fit starts" in line for line in said)
    assert result.effects == ("sensor_delay",), result.explanation
    assert result.as_dict()["unfitted_hypotheses"] == ["bore_sensor_offset"]
