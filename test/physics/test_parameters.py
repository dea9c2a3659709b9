"""Derived parameters, seed eqs. 2-20, against the values physics.md states."""

from __future__ import annotations

import math

import pytest

from brake_hil.physics.parameters import (
    chamber_volumes,
    derive_parameters,
    effective_bulk_modulus,
    line_inertance,
    line_resistance,
    restricted_volume_coefficient,
    reynolds_number,
    seal_properties,
    valve_resistance,
)
from brake_hil.physics.rig import Rig


def test_seal_threshold_stiffness_and_slip_displacement(default_rig: Rig) -> None:
    seal = seal_properties(default_rig)
    assert seal.friction_threshold == pytest.approx(156.0, rel=0.01)  # F_fs per seal
    assert seal.static_stiffness == pytest.approx(1.16e7, rel=0.01)  # k_s
    assert seal.slip_threshold == pytest.approx(13.4e-6, rel=0.01)  # c_s


def test_line_resistance_and_inertance(default_rig: Rig) -> None:
    fluid = default_rig.fluid
    assert line_resistance(default_rig.hard_pipe, fluid.viscosity) == pytest.approx(
        4.7e9, rel=0.01
    )
    assert line_resistance(default_rig.hose, fluid.viscosity) == pytest.approx(1.9e9, rel=0.03)
    assert line_inertance(default_rig.hard_pipe, fluid.density) == pytest.approx(2.6e8, rel=0.01)
    assert line_inertance(default_rig.hose, fluid.density) == pytest.approx(1.0e8, rel=0.05)


def test_bulk_modulus_and_bore_compliance_at_0_9_mpa(default_rig: Rig) -> None:
    assert effective_bulk_modulus(default_rig, 0.9e6) == pytest.approx(3.7e8, rel=0.02)
    params = derive_parameters(default_rig, 0.9e6)
    assert params.bore_compliance == pytest.approx(9.3e-14, rel=0.01)
    assert effective_bulk_modulus(default_rig, 2.0e6) > effective_bulk_modulus(default_rig, 0.9e6)


def test_default_seal_terms_are_the_seed_operating_point(default_rig: Rig) -> None:
    params = derive_parameters(default_rig)
    k_s = seal_properties(default_rig).static_stiffness
    assert 0.5 * params.effective_hydraulic_stiffness / k_s == pytest.approx(0.29)
    eta = (
        params.effective_hydraulic_damping
        * 2
        * math.pi
        * 5.0
        / params.effective_hydraulic_stiffness
    )
    assert eta == pytest.approx(0.93)


def test_washers_move_volume_from_master_cylinder_to_bore(default_rig: Rig) -> None:
    five = Rig(**{**default_rig.__dict__, "washers": 5})
    v_i1, v_b1 = chamber_volumes(default_rig)
    v_i5, v_b5 = chamber_volumes(five)
    washer_volume = 2 * math.pi * 0.02**2 * 4 * 1.5e-3
    assert v_b5 - v_b1 == pytest.approx(washer_volume)
    assert v_i1 - v_i5 == pytest.approx(washer_volume)


def test_valve_equations_and_reynolds_number(default_rig: Rig) -> None:
    coefficient = 1.0e-6
    assert valve_resistance(coefficient, 1050 * 9.81, 1.0e5) == pytest.approx(
        2 * math.sqrt(1050 * 9.81 * 1.0e5) / coefficient
    )
    assert restricted_volume_coefficient(1.0, 1.0, 2.0) == pytest.approx(0.25)
    flow = 1e-6  # m^3/s, a typical 5 Hz peak
    assert reynolds_number(flow, default_rig.hose, 1050, 0.008) < 2000.0


def test_model_mapping_overrides_derived_values(default_rig: Rig) -> None:
    base = derive_parameters(default_rig)
    rig = Rig(
        **{**default_rig.__dict__, "model_overrides": {"k_eh": 1e6, "R_v": 1.3e11, "C_b": 1e-13}}
    )
    params = derive_parameters(rig)
    assert params.effective_hydraulic_stiffness == 1e6
    assert params.bore_compliance == 1e-13
    assert params.line_resistance - base.line_resistance == pytest.approx(1.3e11 - 3.2e10)
