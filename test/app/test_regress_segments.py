"""``regress`` per segment: a procedure's sweep and ramps regress as its pulsing does."""

from __future__ import annotations

import copy
from typing import Any

import pytest

from brake_hil.app.regress import (
    ReplayResult,
    baseline_document,
    compare_with_baseline,
    replay_recording,
)
from brake_hil.app.simulate import run_simulate
from brake_hil.io.recording_reader import read_recording
from test.conftest import CONFIG

RIG = CONFIG / "rig_default.yaml"


@pytest.fixture(scope="module")
def procedure(tmp_path_factory: pytest.TempPathFactory) -> ReplayResult:
    """The LTI model's procedure (pulsing at three pressures, sweep, ramps, ABS train)."""
    out = tmp_path_factory.mktemp("procedure") / "run"
    run_simulate(RIG, out, (1.38e6, 2.07e6, 2.76e6), 2.5, seed=2, excitation="procedure")
    return replay_recording(read_recording(out), RIG)


def _statuses(result: ReplayResult, baseline: dict[str, Any]) -> dict[tuple[str, str], str]:
    checks = compare_with_baseline({"run": result}, baseline)
    return {(c.segment, f"{c.channel} {c.metric}"): c.status for c in checks}


def test_a_replay_with_steady_pulsing_scores_every_other_segment_too(
    procedure: ReplayResult,
) -> None:
    assert procedure.basis == "steady_cycles" and len(procedure.segments) == 3
    kinds = {s["kind"] for s in procedure.scored_segments if s.get("metrics")}
    assert {"pulsing", "sweep", "ramp", "hold", "modulated"} <= kinds
    sweep = next(s for s in procedure.scored_segments if s["kind"] == "sweep")
    assert "response" not in sweep["metrics"]["p_b"]  # the summary, not every band
    # the live model at the run's mean p_i, compare's at the sweep's: within a few %
    assert abs(sweep["metrics"]["p_b"]["mean_gain_ratio_pct"] - 100.0) < 2.0


def test_a_segments_metric_that_moved_fails_though_the_pulsing_holds(
    procedure: ReplayResult,
) -> None:
    baseline = baseline_document({"run": procedure})
    statuses = _statuses(procedure, baseline)
    assert set(statuses.values()) == {"ok"}
    assert any(segment.startswith("sweep") for segment, _ in statuses)
    moved = copy.deepcopy(baseline)
    sweep = next(s for s in moved["bags"]["run"]["segment_metrics"] if s["kind"] == "sweep")
    sweep["metrics"]["x_c"]["mean_phase_error_deg"] += 2.0  # a model that lags more now
    statuses = _statuses(procedure, moved)
    failed = {key: status for key, status in statuses.items() if status != "ok"}
    assert list(failed.values()) == ["MOVED"]
    [(segment, metric)] = failed
    assert segment.startswith("sweep ") and metric == "x_c mean_phase_error_deg"


def test_a_segment_gained_or_lost_fails_and_an_old_baseline_is_still_read(
    procedure: ReplayResult,
) -> None:
    baseline = baseline_document({"run": procedure})
    stored = baseline["bags"]["run"]["segment_metrics"]
    ramp = next(k for k, s in enumerate(stored) if s["kind"] == "ramp")
    missing = copy.deepcopy(baseline)
    del missing["bags"]["run"]["segment_metrics"][ramp]  # the replay holds one more
    assert "NEW" in _statuses(procedure, missing).values()
    extra = copy.deepcopy(baseline)
    ghost = {**stored[ramp], "t_start": 500.0, "t_end": 510.0}
    extra["bags"]["run"]["segment_metrics"].append(ghost)  # one the replay no longer holds
    lost = {k: v for k, v in _statuses(procedure, extra).items() if v != "ok"}
    assert list(lost.values()) == ["LOST"] and next(iter(lost))[0].startswith("ramp 500.0")
    old = copy.deepcopy(baseline)
    del old["bags"]["run"]["segment_metrics"]  # a baseline written before they were kept
    statuses = _statuses(procedure, old)
    assert set(statuses.values()) == {"ok"} and {s for s, _ in statuses} == {""}
