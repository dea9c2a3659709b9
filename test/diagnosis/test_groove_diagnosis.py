"""A groove named with its resolved asymmetry; plain stick-slip kept, saying what it resolves."""

from __future__ import annotations

import json

from brake_hil.diagnosis.diagnose import Diagnosis, diagnose
from brake_hil.physics.rig import Rig
from brake_hil.virtual_rig import make_effect, seed_pulsing, simulate_rig


def _diagnosed(rig: Rig, effect: str, seed: int) -> Diagnosis:
    run = simulate_rig(
        rig, [make_effect(effect, 1.0)], seed_pulsing((1.38e6, 2.76e6), pulsing_s=4.0), seed=seed
    )
    return diagnose(run.as_recording(), rig)


def test_a_groove_is_named_with_its_asymmetry_resolved(default_rig: Rig) -> None:
    """Family a's groove (release 1.4, apply 0.6 of k_eh): the release/apply ratio 2.3."""
    result = _diagnosed(default_rig, "seal_groove_asymmetry", seed=11)
    assert result.effects == ("seal_groove_asymmetry",), result.explanation
    groove = json.loads(json.dumps(result.as_dict()))["verdict"]["groove_asymmetry"]
    assert groove["resolved"] is True and groove["named"] is True
    assert groove["answer"] == "asymmetric"
    low, high = groove["interval"]
    assert 1.0 < low <= groove["apply_release_ratio"] <= high
    assert "groove asymmetry resolved" in result.explanation


def test_symmetric_stick_slip_is_not_called_a_groove(default_rig: Rig) -> None:
    """Plain stick-slip stays stick-slip, and says what the recording resolves of a groove:
    "not resolved" only when its interval neither excludes nor bounds a symmetric seal."""
    result = _diagnosed(default_rig, "seal_stick_slip", seed=12)
    assert result.effects == ("seal_stick_slip",), result.explanation
    groove = json.loads(json.dumps(result.as_dict()))["verdict"]["groove_asymmetry"]
    assert groove["named"] is False
    assert groove["answer"] != "asymmetric" or "does not fit" in result.explanation
    low, high = groove["interval"]
    if groove["answer"] == "not resolved":
        assert groove["resolved"] is False and low < 1.0 < high
        assert "stick-slip; groove asymmetry not resolved" in result.explanation
    else:
        assert groove["resolved"] is True
        assert "groove asymmetry not resolved" not in result.explanation
    assert "seal_stick_slip+seal_groove_asymmetry" not in {
        "+".join(h.effects) for h in result.hypotheses
    }  # the groove holds stick-slip: no pair of the two
