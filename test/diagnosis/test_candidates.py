"""Every candidate model honours the same contract (one parametrised test walks them all)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from brake_hil.diagnosis.candidates import CANDIDATES
from brake_hil.diagnosis.candidates.base import Candidate, Context, Draft
from brake_hil.diagnosis.engine import ModelSpec, simulate_batch
from brake_hil.physics.excitation import pulsing_profile
from brake_hil.physics.parameters import chamber_volumes, derive_parameters, seal_properties
from brake_hil.physics.rig import Rig
from brake_hil.topics import EFFECT_NAMES
from test.conftest import PROJECT

INTERFACE = PROJECT.parent / "shared" / "docs" / "interface.md"


def test_there_is_one_candidate_per_effect_of_the_interface() -> None:
    assert tuple(c.name for c in CANDIDATES) == EFFECT_NAMES
    if INTERFACE.exists():
        text = INTERFACE.read_text()
        for name in EFFECT_NAMES:
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
    assert re.search(r"seed|eq\.|Merritt|Andrade|SAE|Boyle", description), "names its source"
    assert candidate.signature
    context = _context(default_rig)
    start = candidate.start(context)
    assert start.size == len(candidate.parameters) >= 1
    for value, parameter in zip(start, candidate.parameters):
        assert parameter.low <= value <= parameter.high, parameter.name
        assert parameter.unit
        assert parameter.low < parameter.high
    params = derive_parameters(default_rig, 1.08e6)
    draft = Draft([params, params])
    theta = np.vstack([start, np.array([p.high for p in candidate.parameters])])
    candidate.fill(draft, theta, context)
    spec = ModelSpec(tuple(draft.params), **draft.fields)  # type: ignore[arg-type]
    _, pressure = pulsing_profile((1.38e6,), ramp_s=0.5, pulsing_s=1.0)
    outputs = simulate_batch(spec, pressure[::2], 2e-3)
    assert outputs.shape == (2, 3, pressure[::2].size)
    assert np.all(np.isfinite(outputs))
    assert not np.allclose(outputs[0], outputs[1]), "its parameters change the outputs"
    assert isinstance(candidate.consistent({}), bool)
