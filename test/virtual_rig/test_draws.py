"""Benchmark cases drawn over the whole contract: every toleranced value, with and without air."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from brake_hil.errors import EffectError
from brake_hil.virtual_rig import seed_pulsing, simulate_rig
from brake_hil.virtual_rig.cases import (
    DEGASSED_AIR_FRACTION,
    case_excitation,
    case_nominal,
    label,
    nominal_rigs,
    plan_cases,
    select_cases,
    truth_rig,
)
from brake_hil.virtual_rig.draws import (
    NARROW_SPAN,
    PERTURBED_KEYS,
    contract_span,
    draw_uniform_errors,
    spanned_keys,
)

GEOMETRY = ("bore.length", "pistons.diameter", "pistons.mass", "fluid.density", "hose.wall")


def test_every_toleranced_value_of_the_rig_file_is_drawn_geometry_included() -> None:
    nominal = nominal_rigs()["one_washer_open"]
    keys = set(spanned_keys(nominal))
    assert set(GEOMETRY) | set(PERTURBED_KEYS) <= keys
    assert "excitation_hz" not in keys and "washers" not in keys
    for spec in plan_cases(30, seed=4):
        rig = nominal_rigs()[spec.nominal_key]
        assert set(spec.parameter_errors) == keys, spec.number
        for key, error in spec.parameter_errors.items():
            if spec.kind == "out_of_tolerance" and key == spec.off_key:
                continue
            if spec.kind == "more_air" and key == "fluid.air_fraction":
                continue
            assert abs(error) <= contract_span(rig, key) + 1e-9, key
        truth = truth_rig(rig, spec.parameter_errors, "truth")
        assert truth.piston_diameter != rig.piston_diameter
        assert truth.bore_length != rig.bore_length


def test_the_draw_is_uniform_over_the_whole_tolerance() -> None:
    """A normal of half a tolerance (the stored sets' draw) puts 32 % beyond half; uniform 50 %."""
    nominal = nominal_rigs()["one_washer_open"]
    rng = np.random.default_rng(12)
    draws = [draw_uniform_errors(nominal, rng) for _ in range(1500)]
    for key, half in (("caliper.stiffness", 0.25), ("needle_valve.resistance", 0.4),
                      ("bore.length", 0.1), ("fluid.air_fraction", NARROW_SPAN),
                      ("seal.youngs_modulus", NARROW_SPAN)):  # fmt: skip
        errors = np.array([d[key] for d in draws]) / half
        assert np.all(np.abs(errors) <= 1.0 + 1e-3), key
        assert 0.45 < np.mean(np.abs(errors) > 0.5) < 0.55, key
        assert np.max(np.abs(errors)) > 0.98, key
        assert stats.kstest(errors, stats.uniform(-1.0, 2.0).cdf).pvalue > 1e-3, key
    poisson = np.array([d["seal.poisson_ratio"] for d in draws])
    assert np.all(0.49 * (1.0 + poisson) < 0.5)  # kept physical (below 0.5)


def test_the_stored_sets_draw_is_kept_behind_the_seed_span() -> None:
    specs = plan_cases(28, seed=3, span="seed")
    assert all(set(s.parameter_errors) == set(PERTURBED_KEYS) for s in specs)
    assert {s.kind for s in specs} == {"null", "single", "pair", "unexplained"}
    assert all(s.rig_air == "linearised" and not s.air for s in specs)
    contract = plan_cases(26, seed=3)
    assert [(s.kind, s.effects) for s in contract] == [(s.kind, s.effects) for s in specs[:26]]
    with pytest.raises(EffectError, match="only with the contract span"):
        select_cases(2, seed=3, kinds=("more_air",), span="seed")
    with pytest.raises(EffectError, match="unknown span"):
        plan_cases(2, seed=3, span="wide")


def test_nulls_come_degassed_and_with_the_rig_files_air_following_the_pressure() -> None:
    nulls = select_cases(4, seed=9, kinds=("null",))
    assert [s.air for s in nulls] == ["degassed", "rig_file", "degassed", "rig_file"]
    for spec in nulls:
        nominal = case_nominal(spec)
        truth = truth_rig(nominal, spec.parameter_errors, "truth")
        document = label(spec, truth, case_excitation(spec, truth, 1.0))
        assert document["span"] == "contract" and document["air"] == spec.air
        assert document["rig_air"] == "instantaneous" and document["expected_effects"] == []
        if spec.air == "degassed":
            assert nominal.fluid.air_fraction == DEGASSED_AIR_FRACTION
            assert truth.fluid.air_fraction == pytest.approx(1e-6, rel=NARROW_SPAN + 1e-9)
        else:
            assert nominal.fluid.air_fraction == 0.001
            assert truth.fluid.air_fraction == pytest.approx(1e-3, rel=NARROW_SPAN + 1e-9)


def test_the_new_kinds_are_labelled_with_their_key_and_ratio() -> None:
    far = select_cases(12, seed=5, kinds=("out_of_tolerance",))
    for spec in far:
        nominal = case_nominal(spec)
        truth = truth_rig(nominal, spec.parameter_errors, "truth")
        document = label(spec, truth, case_excitation(spec, truth, 1.0))
        assert document["kind"] == "out_of_tolerance" and document["expected_effects"] == []
        key, ratio = document["key"], document["ratio"]
        assert key == spec.off_key and ratio == pytest.approx(1 + spec.parameter_errors[key])
        off = abs(ratio - 1.0) / nominal.tolerance(key)
        assert 1.0 - 1e-3 <= off <= 2.0 + 1e-3, (key, ratio)
        others = {k: e for k, e in spec.parameter_errors.items() if k != key}
        assert all(abs(e) <= contract_span(nominal, k) + 1e-9 for k, e in others.items())
    assert len({s.off_key for s in far}) > 4 and {
        s.parameter_errors[s.off_key] > 0 for s in far
    } == {
        True,
        False,
    }
    for spec in select_cases(6, seed=5, kinds=("more_air",)):
        nominal = case_nominal(spec)
        truth = truth_rig(nominal, spec.parameter_errors, "truth")
        document = label(spec, truth, case_excitation(spec, truth, 1.0))
        assert document["expected_effects"] == [] and document["air"] == "more"
        assert 2.0 <= document["ratio"] <= 3.0
        assert truth.fluid.air_fraction == pytest.approx(document["ratio"] * 0.001)
    plan = plan_cases(56, seed=5)
    assert [s.kind for s in plan[26:28]] == ["out_of_tolerance", "more_air"]
    assert sum(s.kind in ("out_of_tolerance", "more_air") for s in plan) == 4


def test_the_rig_air_at_the_instantaneous_pressure_swings_within_a_cycle_same_mean() -> None:
    rig = nominal_rigs()["one_washer_open"]
    excitation = seed_pulsing((2.07e6,), pulsing_s=2.0)
    compliance = {}
    for law in ("linearised", "instantaneous"):
        run = simulate_rig(rig, (), excitation, rig_air=law)
        steady = run.time > run.time[-1] - 1.0  # the last five cycles
        compliance[law] = run.internals["bore_compliance"][steady]
        assert run.plant.rig_air == law
    linear, instant = compliance["linearised"], compliance["instantaneous"]
    assert np.ptp(linear) / np.mean(linear) < 0.02  # constant within a cycle
    # the air (about 0.4 of the bore's compliance at 1.6 MPa) swings as 1/p over +-28 %
    swing = np.ptp(instant) / np.mean(instant)
    assert 0.15 < swing < 0.5, swing
    assert np.mean(instant) == pytest.approx(np.mean(linear), rel=0.05)
    with pytest.raises(EffectError, match="law of the rig's own air"):
        simulate_rig(rig, (), excitation, rig_air="adiabatic")
