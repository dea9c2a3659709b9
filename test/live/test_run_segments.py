"""The live comparator's run kept whole and scored per segment, as ``compare`` scores it."""

from __future__ import annotations

import numpy as np
import pytest

from brake_hil.analysis.segment_comparison import score_prediction
from brake_hil.app.chain_result import judge_cycles
from brake_hil.io.recording_reader import read_recording
from brake_hil.live.model_file import load_model
from brake_hil.live.run_segments import RunLog, score_run, segment_lines
from brake_hil.topics import OUTPUT_CHANNELS
from test.conftest import PROJECT

RAMP = PROJECT / "bags" / "ramp_one_washer"
START_NS = 1_700_000_000_000_000_000
NONE = dict.fromkeys(OUTPUT_CHANNELS, 0)
"""No steady cycle, per channel."""


def _fed(lose_every: int = 0) -> tuple[RunLog, dict[str, np.ndarray], object]:
    """The ramp bag and its live model's predictions fed in batches, as the comparator takes them.

    ``lose_every``: drop every n-th measured ``x_c`` sample (lost on the way).
    """
    recording = read_recording(RAMP)
    model = load_model(PROJECT / "bags" / "ramp_one_washer.rig.yaml", 1.0e6)
    stepper = model.stepper()
    predicted = np.array([stepper.step(p) for p in recording.master_cylinder_pressure]).T
    stamps = START_NS + np.round(recording.time * 1e9).astype(np.int64)
    series = {"p_i": recording.master_cylinder_pressure}
    for channel, pred, (_, meas) in zip(OUTPUT_CHANNELS, predicted, recording.measured().items()):
        series[f"{channel}_pred"], series[f"{channel}_meas"] = pred, meas
    log = RunLog(0.001)
    for start in range(0, stamps.size, 50):  # 50 ms takes
        for name, values in series.items():
            keep = np.arange(start, min(start + 50, stamps.size))
            if lose_every and name == "x_c_meas":
                keep = keep[keep % lose_every != 0]
            log.extend(name, stamps[keep].tolist(), values[keep].tolist())
    return log, dict(zip(OUTPUT_CHANNELS, predicted)), recording


def test_a_ramp_received_live_is_scored_per_segment_as_regress_scores_its_recording() -> None:
    log, predicted, recording = _fed()
    document = score_run(log, 5.0)
    direct = score_prediction(recording, predicted, 5.0, 1.0e6)  # type: ignore[arg-type]
    assert [s["kind"] for s in document["segments"]] == [s.segment.kind for s in direct.segments]
    assert "ramp" in [s["kind"] for s in document["segments"]]
    for live, offline in zip(document["segments"], direct.segments):
        assert live["t_start"] == pytest.approx(offline.segment.t_start, abs=0.01)
        for channel, metrics in offline.metrics.items():
            for key, value in metrics.items():
                if isinstance(value, float):
                    assert live["metrics"][channel][key] == pytest.approx(value, rel=1e-6)
    assert document["interpolated_share"] == 0.0 and document["dropped_samples"] == 0
    lines = segment_lines(document)
    assert any(line.startswith("ramp ") and "map_gain_ratio_pct" in line for line in lines)
    assert not any(line.startswith("idle") for line in lines)
    judged = judge_cycles(NONE, NONE, None, {"segments": document["segments"]})
    assert judged.level == 0 and "segments scored each (ramp, hold)" in judged.line


def test_lost_samples_are_interpolated_and_said() -> None:
    log, _, _ = _fed(lose_every=10)
    document = score_run(log, 5.0)
    assert document["interpolated_share"] == pytest.approx(0.1, abs=0.01)
    assert any(s.get("metrics") for s in document["segments"])


def test_a_run_with_nothing_to_score_says_why_and_is_not_a_pass() -> None:
    log = RunLog(0.001)
    empty = score_run(log, 5.0)
    assert empty["segments"] == [] and "no p i sample" in empty["unscored"]
    stamps = list(range(START_NS, START_NS + 3_000_000_000, 1_000_000))
    for name in ("p_i", *(f"{c}_{s}" for c in OUTPUT_CHANNELS for s in ("pred", "meas"))):
        log.extend(name, stamps, [1.0e5] * len(stamps))  # held still: nothing varies
    still = score_run(log, 5.0)
    assert still["segments"] == [] and still["unscored"]
    assert segment_lines(still)[0].startswith("no segment scored: ")
    judged = judge_cycles(NONE, NONE, None, still)
    assert judged.level == 1 and judged.line.startswith("nothing compared")


def test_a_run_past_the_limit_keeps_its_start_and_counts_the_rest() -> None:
    log = RunLog(0.001, max_s=1.0)
    log.extend("p_i", list(range(1500)), [0.0] * 1500)
    assert log.samples("p_i") == 1000 and log.dropped == 500
