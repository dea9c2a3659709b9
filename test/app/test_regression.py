"""The comparator's scoring and the replay regression's baseline logic (no ROS)."""

from __future__ import annotations

from dataclasses import replace
import json
from pathlib import Path

import numpy as np
import pytest

from brake_hil.analysis.comparison import compare
from brake_hil.analysis.stamp_scoring import (
    DEFAULT_TOLERANCES,
    PairedWindow,
    StampPairer,
    Thresholds,
    evaluate_cycle,
    peak_stamp_ns,
)
from brake_hil.app.regress import (
    FAR_OFF_PTP_PCT,
    MetricCheck,
    baseline_document,
    compare_with_baseline,
    far_off,
    load_baseline,
    plan_replays,
    replay_recording,
)
from brake_hil.diagnosis.calibration import UNCERTAIN
from brake_hil.diagnosis.ptp_spread import ptp_spread
from brake_hil.diagnosis.rig_findings import FLAG_SIGMAS
from brake_hil.errors import BaselineError, RecordingError
from brake_hil.io.recording_reader import read_recording
from brake_hil.physics.rig import load_rig
from test.conftest import CONFIG, PROJECT

BAG = PROJECT / "bags" / "one_washer_lti"
RIG = CONFIG / "rig_default.yaml"
MS = 1_000_000


def test_pairer_pairs_by_stamp_in_either_order_and_drops_the_unpaired() -> None:
    pairer = StampPairer(capacity=10, max_pending=3)
    pairer.add_measured(2, 20.0)
    pairer.add_predicted(1, 1.5)
    pairer.add_predicted(2, 2.5)
    pairer.add_measured(1, 10.0)
    stamps, predicted, measured = pairer.window()
    assert stamps.tolist() == [1, 2]
    assert predicted.tolist() == [1.5, 2.5] and measured.tolist() == [10.0, 20.0]
    for stamp in range(10, 15):  # never measured
        pairer.add_predicted(stamp, 0.0)
    assert pairer.unpaired_predicted == 2 and pairer.pending == (3, 0)


def test_thresholds_give_ok_warn_error() -> None:
    thresholds = Thresholds()
    good = {"ptp_ratio_pct": 104.0, "tau_over_T_pct": 1.5, "nrmse": 0.04}
    assert thresholds.level(good) == 0
    assert thresholds.level({**good, "nrmse": 0.2}) == 1
    assert thresholds.level({**good, "ptp_ratio_pct": 70.0}) == 2
    assert thresholds.level({**good, "tau_over_T_pct": float("nan")}) == 2


def _window(gain: float, lag_ms: int, seconds: float = 3.0, ramp: bool = False) -> PairedWindow:
    stamps = 1_700_000_000 * 10**9 + np.arange(round(seconds * 1000), dtype=np.int64) * MS
    t = (stamps - stamps[0]) / 1e9
    if ramp:
        measured = 1e6 * t
        return PairedWindow(stamps, measured, measured)
    measured = 1e6 + 3e5 * np.sin(2 * np.pi * 5 * t)
    predicted = 1e6 + gain * 3e5 * np.sin(2 * np.pi * 5 * (t + lag_ms / 1000))
    return PairedWindow(stamps, predicted, measured)


def test_a_cycle_of_a_known_gain_and_lead_is_scored_as_such() -> None:
    window = _window(gain=1.1, lag_ms=4)
    peak = peak_stamp_ns(window)
    assert (peak - int(window.stamps_ns[0])) % (200 * MS) == pytest.approx(50 * MS, abs=MS)
    end = peak + 11 * 200 * MS  # cycles from peak to peak: 10 cycles after the leading guard
    result = evaluate_cycle(window, end, window_cycles=10)
    assert result.steady, result.reason
    assert result.cycle is not None and result.window is not None
    assert result.window["ptp_ratio_pct"] == pytest.approx(110.0, abs=0.2)
    assert result.cycle["tau_over_T_pct"] == pytest.approx(2.0, abs=0.1)  # 4 ms of 200 ms
    assert result.window["cycles"] == 10 and result.cycle["cycles"] == 1


def test_ramps_and_uncovered_windows_are_not_scored() -> None:
    ramp = _window(1.0, 0, ramp=True)
    end = int(ramp.stamps_ns[0]) + 11 * 200 * MS
    assert not evaluate_cycle(ramp, end).steady
    short = _window(1.0, 0, seconds=1.0)
    result = evaluate_cycle(short, int(short.stamps_ns[0]) + 800 * MS, window_cycles=10)
    assert not result.steady and "not covered" in result.reason


def test_replay_scores_the_bundled_bag_as_compare_does() -> None:
    recording = read_recording(BAG)
    result = replay_recording(recording, RIG)
    assert result.samples == 18000 and len(result.segments) == 3
    assert result.replay_factor > 0.0  # its speed is a benchmark's figure, not a test's
    from brake_hil.physics.rig import load_rig

    reference = compare(recording, load_rig(RIG)).metrics()
    for channel in ("p_b", "F_k", "x_c"):
        ours, theirs = result.metrics[channel], reference[channel]
        assert ours["ptp_ratio_pct"] == pytest.approx(theirs["ptp_ratio_pct"], abs=0.2)
        assert ours["tau_over_T_pct"] == pytest.approx(theirs["tau_over_T_pct"], abs=0.1)
        assert ours["nrmse"] == pytest.approx(theirs["nrmse"], rel=0.02)


def test_metrics_past_their_tolerance_are_flagged(tmp_path: Path) -> None:
    result = replay_recording(read_recording(BAG), RIG)
    document = baseline_document({"bag": result})
    checks = compare_with_baseline({"bag": result}, document)
    assert {c.status for c in checks} == {"ok"}
    document["bags"]["bag"]["metrics"]["x_c"]["nrmse"] += 2 * DEFAULT_TOLERANCES["nrmse"]
    moved = [c for c in compare_with_baseline({"bag": result}, document) if c.status != "ok"]
    assert [(c.channel, c.metric, c.status) for c in moved] == [("x_c", "nrmse", "MOVED")]
    assert compare_with_baseline({"other": result}, document)[0].status == "NEW"
    assert MetricCheck("b", "p_b", "nrmse", 0.1, 0.1049, 0.005).status == "ok"


def test_bad_baselines_are_refused_naming_the_file(tmp_path: Path) -> None:
    with pytest.raises(BaselineError, match="no such baseline"):
        load_baseline(tmp_path / "missing.json")
    broken = tmp_path / "broken.json"
    broken.write_text("{not json", encoding="utf-8")
    with pytest.raises(BaselineError, match=str(broken)):
        load_baseline(broken)
    wrong = tmp_path / "wrong.json"
    wrong.write_text(json.dumps({"bags": {"x": {"metrics": 1}}}), encoding="utf-8")
    with pytest.raises(BaselineError, match="'x' has no 'metrics'"):
        load_baseline(wrong)


def test_the_shipped_baseline_matches_the_bundled_bag() -> None:
    baseline = load_baseline(PROJECT / "bags" / "baseline.json")
    # each bag with the model file it was replayed through: its own rig file, beside it
    model = baseline["bags"]["one_washer_lti"]["model_file"]
    assert model == "one_washer_lti.rig.yaml" and "model_file" not in baseline
    result = replay_recording(read_recording(BAG), PROJECT / "bags" / model)
    checks = compare_with_baseline({"one_washer_lti": result}, baseline)
    assert [c for c in checks if c.status != "ok"] == []


def test_far_off_is_a_ptp_ratio_past_twice_what_the_rig_files_tolerances_allow() -> None:
    metrics = {
        "p_b": {"ptp_ratio_pct": 124.9},
        "F_k": {"ptp_ratio_pct": 180.79},
        "x_c": {"ptp_ratio_pct": float("nan")},
    }
    spread = {"p_b": 3.0, "F_k": 41.0, "x_c": 29.0}
    assert FLAG_SIGMAS == 2.0
    assert far_off(metrics, spread) == [
        "p_b ptp 124.9 % (100 ± 6 % allowed)",
        "x_c ptp nan % (100 ± 58 % allowed)",
    ]
    # without the rig's spread (no rig file, no steady pulsing): the comparator's ERROR level
    assert FAR_OFF_PTP_PCT == Thresholds().ptp_ratio_error_pct == 25.0
    assert far_off(metrics) == [
        "F_k ptp 180.8 % (100 ± 25 % allowed)",
        "x_c ptp nan % (100 ± 25 % allowed)",
    ]


def test_the_ptp_spread_is_the_rig_files_tolerances_pushed_through_the_model() -> None:
    """A restricted valve sets the caliper's amplitude, so its ±40 % widens the F_k ptp's
    spread past the open rig's (both carry the pistons' area, a fifth of the force); a rig
    file that says every value is known exactly (tolerance 0) allows none."""
    spreads = {}
    for name in ("one_washer_open", "one_washer_restricted"):
        bag = PROJECT / "bags" / name
        spreads[name] = ptp_spread(
            read_recording(bag), load_rig(bag.with_name(name + ".rig.yaml"))
        )
    open_valve, restricted = spreads["one_washer_open"], spreads["one_washer_restricted"]
    assert all(value > 1.0 for value in (*open_valve.values(), *restricted.values()))
    assert restricted["F_k"] > 1.4 * open_valve["F_k"]
    assert open_valve["F_k"] > 15.0  # the piston diameter's 10 % is a fifth of the area
    exact = load_rig(RIG)
    exact = replace(exact, tolerances={u.tolerance_key: 0.0 for u in UNCERTAIN})
    assert ptp_spread(read_recording(BAG), exact) == {"p_b": 0.0, "F_k": 0.0, "x_c": 0.0}


def test_plan_replays_each_recording_through_its_own_rig_unless_told(tmp_path: Path) -> None:
    bags = PROJECT / "bags"
    plan = plan_replays([bags / "one_washer_open", bags / "truth", bags / "README.md"])
    assert plan.jobs == [(bags / "one_washer_open", bags / "one_washer_open.rig.yaml")]
    assert plan.sources == {bags / "one_washer_open": "beside the recording"}
    assert plan.refused == {
        str(bags / "truth"): f"{bags / 'truth'}: no recording in this folder",
        str(bags / "README.md"): f"{bags / 'README.md'}: not a recording (a rosbag2 folder, "
        ".mcap or .db3)",
    }
    told = plan_replays([bags / "one_washer_open"], model_file=RIG)
    assert told.jobs == [(bags / "one_washer_open", RIG)] and told.refused == {}
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "metadata.yaml").write_text("x")
    bare = plan_replays([tmp_path / "run"])
    assert bare.jobs == [] and "no rig file beside it" in bare.refused[str(tmp_path / "run")]
    assert "pass --model" in bare.refused[str(tmp_path / "run")]
    with pytest.raises(RecordingError, match="no_such: no such recording"):
        plan_replays([tmp_path / "no_such"])
