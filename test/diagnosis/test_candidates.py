"""Every candidate model honours the same contract (one parametrised test walks them all),
points to its catalogue entry, and a candidate registered at run time joins them."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
import re

import numpy as np
import pytest

from brake_hil.diagnosis.candidates import (
    CANDIDATES,
    candidate,
    register_candidate,
    unregister_candidate,
)
from brake_hil.diagnosis.candidates.base import Candidate, CandidateParameter, Context, Draft
from brake_hil.diagnosis.engine import Coupling, Entry, Term, simulate_batch
from brake_hil.errors import EffectError
from brake_hil.physics import catalogue
from brake_hil.physics.catalogue import CATALOGUE, OUT_OF_LIBRARY, EffectEntry, effect_names
from brake_hil.physics.excitation import pulsing_profile
from brake_hil.physics.parameters import chamber_volumes, derive_parameters, seal_properties
from brake_hil.physics.rig import Rig
from test.conftest import PROJECT

INTERFACE = PROJECT.parent / "shared" / "docs" / "interface.md"


def test_there_is_one_candidate_per_effect_of_the_interface() -> None:
    assert tuple(c.name for c in CANDIDATES) == effect_names()
    if INTERFACE.exists():
        text = INTERFACE.read_text()
        for name in effect_names():
            assert f"`{name}`" in text


def _context(rig: Rig) -> Context:
    return Context(
        seal=seal_properties(rig),
        bore_volume=chamber_volumes(rig)[1],
        flow_amplitude=2e-6,
        transducer_distance=rig.transducer_distance,
        bore_friction_coefficient=rig.bore_friction_coefficient,
        time_reference=1.0,
    )


@pytest.mark.parametrize("candidate", CANDIDATES, ids=lambda c: c.name)
def test_candidate_contract(candidate: Candidate, default_rig: Rig) -> None:
    description = candidate.describe()
    assert len(description) > 150, "a paragraph of physics"
    assert re.search(r"paper|eq\.|Merritt|Andrade|SAE|Boyle", description), "names its source"
    assert candidate.signature
    context = _context(default_rig)
    start = candidate.start(context)
    assert start.size == len(candidate.parameters) >= 1
    for value, parameter in zip(start, candidate.parameters):
        assert parameter.low <= value <= parameter.high, parameter.name
        assert parameter.unit
        assert parameter.low < parameter.high
    for other in candidate.other_starts(context):
        assert other.shape == start.shape and not np.array_equal(other, start)
        for value, parameter in zip(other, candidate.parameters):
            assert parameter.low <= value <= parameter.high, parameter.name
    params = derive_parameters(default_rig, 1.08e6)
    draft = Draft([params, params])
    theta = np.vstack([start, np.array([p.high for p in candidate.parameters])])
    candidate.fill(draft, theta, context)
    spec = draft.spec()
    _, pressure = pulsing_profile((1.38e6,), ramp_s=0.5, pulsing_s=1.0)
    outputs = simulate_batch(spec, pressure[::2], 2e-3)
    assert outputs.shape == (2, 3, pressure[::2].size)
    assert np.all(np.isfinite(outputs))
    assert not np.allclose(outputs[0], outputs[1]), "its parameters change the outputs"
    assert isinstance(candidate.consistent({}), bool)


@pytest.mark.parametrize("name", tuple(CATALOGUE))
def test_every_catalogue_entry_has_exactly_one_candidate_with_its_signature(name: str) -> None:
    entry = CATALOGUE[name]
    pointing = [c for c in CANDIDATES if c.entry == entry]
    assert len(pointing) == 1
    assert pointing[0].name == name
    assert pointing[0].signature == entry.signature
    assert candidate(name) is pointing[0]


@pytest.mark.parametrize("name", tuple(OUT_OF_LIBRARY))
def test_out_of_library_effects_have_no_candidate(name: str) -> None:
    assert not [c for c in CANDIDATES if c.name == name or c.entry == OUT_OF_LIBRARY[name]]
    with pytest.raises(EffectError, match="no candidate"):
        candidate(name)


@dataclass(frozen=True, eq=False)
class _PressureResistance(Term):
    """A line resistance that grows with the bore pressure (through existing mechanisms)."""

    slope: np.ndarray  # -, relative growth per MPa

    pressure_scheduled = True

    def couple(self, coupling: Coupling, row: int, entry: Entry) -> None:
        coupling.line_factor *= 1.0 + float(self.slope[row]) * entry.pressure / 1e6


_ENTRY = EffectEntry(
    name="pressure_thickening",
    title="a fluid whose viscosity grows with pressure",
    physics="Barus: viscosity grows with pressure, and the line resistance with it.",
    source="Barus (1893)",
    signature="p_b lags more at high pressure than at low",
    channels=("p_b",),
    quantities=(catalogue.Quantity("alpha", "1/Pa", "pressure-viscosity coefficient"),),
)


class _PressureThickening(Candidate):
    """Pressure thickening: the line resistance grows with the bore pressure (Barus 1893)."""

    entry = _ENTRY
    parameters = (CandidateParameter("thickening", "1/MPa", 0.0, 2.0, 0.5),)

    def fill(self, draft: Draft, theta: np.ndarray, context: Context) -> None:
        draft.add(_PressureResistance(theta[:, 0].copy()))


@pytest.fixture
def thickening() -> Iterator[Candidate]:
    item = _PressureThickening()
    with pytest.raises(EffectError, match="not in the catalogue"):
        register_candidate(item)
    catalogue.register(_ENTRY)
    try:
        yield register_candidate(item)
    finally:
        unregister_candidate(_ENTRY.name)
        catalogue.unregister(_ENTRY.name)


def test_a_candidate_registered_at_run_time_joins_the_diagnosis(
    thickening: Candidate, default_rig: Rig
) -> None:
    """A new effect through the engine's existing mechanisms: no engine edit."""
    assert CANDIDATES[-1] is thickening
    assert tuple(c.name for c in CANDIDATES) == effect_names()
    assert candidate("pressure_thickening") is thickening
    with pytest.raises(EffectError, match="has a candidate already"):
        register_candidate(_PressureThickening())
    params = derive_parameters(default_rig, 1.08e6)
    draft = Draft([params, params])
    thickening.fill(draft, np.array([[0.0], [1.5]]), _context(default_rig))
    _, pressure = pulsing_profile((1.38e6,), ramp_s=0.5, pulsing_s=1.0)
    outputs = simulate_batch(draft.spec(), pressure[::2], 2e-3)
    lti = simulate_batch(Draft([params]).spec(), pressure[::2], 2e-3)[0]
    assert np.allclose(outputs[0], lti, rtol=1e-9, atol=1e-9 * np.abs(lti).max())
    assert np.ptp(outputs[1, 0]) < np.ptp(lti[0])  # a stiffer line passes less of p_i


def test_unregistered_candidates_leave_the_diagnosis() -> None:
    names = tuple(c.name for c in CANDIDATES)
    assert "pressure_thickening" not in names
    with pytest.raises(EffectError):
        candidate("pressure_thickening")


def test_the_hose_wall_stores_the_same_at_every_operating_pressure(default_rig: Rig) -> None:
    """The bore's compliance falls with pressure (the air of eq. 18); the hose wall's swell
    does not (SAE J1401: one volumetric expansion per pressure), so the hose node is a fixed
    multiple of one reference compliance."""
    from brake_hil.diagnosis.candidates.base import rig_context
    from brake_hil.diagnosis.candidates.hose_compliance import HoseNode

    context = rig_context(default_rig, flow_amplitude=2e-6, time_reference=1.0)
    assert context.reference_compliance == derive_parameters(default_rig).bore_compliance
    pressures = (0.5e6, 1.0e6, 2.0e6)
    draft = Draft([derive_parameters(default_rig, p) for p in pressures])
    assert draft.params[0].bore_compliance > 1.2 * draft.params[-1].bore_compliance
    candidate("hose_compliance").fill(draft, np.tile([0.8, 1.0, 0.03], (3, 1)), context)
    (node,) = [t for t in draft.terms if isinstance(t, HoseNode)]
    assert np.allclose(node.compliance, 0.8 * context.reference_compliance)
    assert np.allclose(node.creep_compliance, node.compliance)


def test_the_thermal_drifts_rival_moves_the_force_and_displacement_zeros(
    default_rig: Rig,
) -> None:
    """``zero_wander``, the rival of a thermal drift: F_k's and x_c's zeros move steadily from
    the training data's middle to the fitted wander at the last sample; p_b and the dynamics
    are unchanged. Its physics holds within the transducers' zero stability (0.1 % of full
    scale: 8.9 N, 0.5 um), not beyond."""
    from brake_hil.diagnosis.candidates.base import rig_context
    from brake_hil.diagnosis.candidates.zero_wander import ZeroWander, stability

    drift = candidate("thermal_drift")
    (rival,) = drift.rivals(drift.start(_context(default_rig)))
    assert isinstance(rival, ZeroWander)
    assert stability("F_k") == pytest.approx(8.9) and stability("x_c") == pytest.approx(5e-7)
    assert rival.holds(np.array([8.0, -4e-7])) and not rival.holds(np.array([12.0, 0.0]))
    assert not rival.holds(np.array([0.0, 6e-7]))
    context = rig_context(default_rig, flow_amplitude=2e-6, time_reference=4.0, last_time=14.0)
    params = derive_parameters(default_rig, 1.08e6)
    _, pressure = pulsing_profile((1.38e6,), ramp_s=0.5, pulsing_s=1.0)
    still, moved = Draft([params]), Draft([params])
    rival.fill(moved, np.array([[5.0, -2e-7]]), context)
    start = np.array([9.0])  # the run's first sample at 9 s of the recording
    plain = simulate_batch(still.spec(), pressure[::2], 2e-3, start_time=start)
    shifted = simulate_batch(moved.spec(), pressure[::2], 2e-3, start_time=start)
    since = 9.0 + 2e-3 * np.arange(plain.shape[-1]) - 4.0  # s from the reference
    np.testing.assert_allclose(shifted[0, 0], plain[0, 0])
    np.testing.assert_allclose(shifted[0, 1] - plain[0, 1], 5.0 * since / 10.0, atol=1e-9)
    np.testing.assert_allclose(shifted[0, 2] - plain[0, 2], -2e-7 * since / 10.0, atol=1e-15)
