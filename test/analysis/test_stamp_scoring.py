"""Pairing by stamp when one side lags: late pairs, not lost ones; the unpaired by reason."""

from __future__ import annotations

import numpy as np

from brake_hil.analysis.stamp_scoring import HORIZON_NS, StampPairer, expected_cycles

MS = 1_000_000
START = 1_700_000_000 * 10**9


def test_a_prediction_stream_5_s_behind_the_measured_still_pairs_every_sample() -> None:
    pairer = StampPairer(capacity=20_000)
    samples, lag = 20_000, 5_000  # 20 s at 1 kHz, predictions 5 s late
    for k in range(samples + lag):
        if k < samples:
            pairer.add_measured(START + k * MS, float(k))
        if k >= lag:
            j = k - lag
            pairer.add_predicted(START + j * MS, float(j) + 0.5)
    assert pairer.paired == samples
    assert pairer.unpaired_predicted == pairer.unpaired_measured == 0
    assert pairer.pending == (0, 0)
    stamps, predicted, measured = pairer.window()
    assert stamps.size == samples and np.all(predicted - measured == 0.5)


def test_a_side_more_than_the_horizon_behind_is_dropped_as_behind() -> None:
    pairer = StampPairer(horizon_ns=1_000 * MS)
    for k in range(3_000):  # 3 s of measurements, no prediction at all
        pairer.add_measured(START + k * MS, 0.0)
    assert pairer.unpaired_measured == 2_000 - 1  # waited more than 1 s of stamps
    assert pairer.unpaired_reasons == {"behind": 1_999, "mismatch": 0}
    assert pairer.pending == (0, 1_001)
    assert pairer.unpaired_now() == {"behind": 1_999, "mismatch": 0, "end": 1_001}


def test_stamps_offset_from_each_other_are_counted_as_never_matching() -> None:
    pairer = StampPairer(horizon_ns=1_000 * MS)
    offset = 500_000  # predictions stamped half a sample off: none ever matches
    for k in range(3_000):
        pairer.add_measured(START + k * MS, 0.0)
        pairer.add_predicted(START + k * MS + offset, 0.0)
    assert pairer.paired == 0
    reasons = pairer.unpaired_reasons
    assert reasons["behind"] == 0 and reasons["mismatch"] == 2 * 1_999
    now = pairer.unpaired_now()
    assert now["mismatch"] + now["end"] == 2 * 1_999 + 2 * 1_001
    assert now["end"] <= 1  # the newest measured sample: its partner's stamp not yet passed


def test_memory_is_bounded_by_the_cap_whatever_the_stamps() -> None:
    pairer = StampPairer(horizon_ns=HORIZON_NS, max_pending=100)
    for k in range(1_000):
        pairer.add_predicted(START + k * MS, 0.0)
    assert pairer.pending == (100, 0) and pairer.unpaired_predicted == 900


def _pulsing(seconds: float, steady_from_s: float) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(round(seconds * 1000)) / 1000.0
    ramp = np.clip(t / steady_from_s, 0.0, 1.0) * 1e6
    pulses = np.where(t >= steady_from_s, 3e5 * np.sin(2 * np.pi * 5 * t), 0.0)
    return (START + np.arange(t.size, dtype=np.int64) * MS), ramp + pulses


def test_expected_cycles_count_the_steady_cycles_the_comparator_scores() -> None:
    stamps, values = _pulsing(8.0, 2.0)  # 6 s of 5 Hz pulsing: 30 cycles
    counts = expected_cycles(stamps, {"p_b": values, "F_k": 2 * values})
    # the first window of 10 cycles must be mostly steady, the last cycle needs a guard
    assert counts["p_b"] == counts["F_k"]
    assert 15 <= counts["p_b"] <= 29
    stamps, ramp = _pulsing(8.0, 8.5)  # a ramp, no pulsing
    assert expected_cycles(stamps, {"p_b": ramp}) == {"p_b": 0}


def test_pairs_taken_seconds_late_and_out_of_order_are_all_held_in_stamp_order() -> None:
    pairer = StampPairer()  # pairs kept for 30 s
    order = np.random.default_rng(3).permutation(10_000)  # 10 s, taken in one shuffled batch
    for k in order:
        pairer.add_measured(START + int(k) * MS, float(k))
    for k in range(10_000):
        pairer.add_predicted(START + k * MS, float(k))
    stamps, predicted, measured = pairer.window()
    assert stamps.size == 10_000 and np.all(np.diff(stamps) == MS)
    assert np.array_equal(predicted, measured)
    since = pairer.window(START + 9_000 * MS)
    assert since.stamps_ns.size == 1_000 and since.stamps_ns[0] == START + 9_000 * MS
