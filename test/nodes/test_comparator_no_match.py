"""The comparator, as its own process, when predictions never match a measurement stamp.

A publisher in the test process sends the three measured and the three predicted channels at
1 kHz: 4 s with equal stamps, then 5 s with the predictions stamped 0.5 ms off (a model that
stamps with its own clock). The comparator must say so: ERROR "no prediction matches a
measurement stamp" on the channels and the summary, a few seconds after the mismatch starts,
and never on the cycles of the matching samples.
"""

from __future__ import annotations

import math
from pathlib import Path
import time
from typing import Any

import pytest

from brake_hil.app.chain import start_node, stop_node
from brake_hil.nodes import common
from brake_hil.nodes.comparator_node import NO_MATCH_S
from brake_hil.topics import MEASURED_OUTPUTS, PREDICTED_OUTPUTS
from test.nodes.faults import MS, SamplePublisher
from test.nodes.harness import Collector, ros_domain, unique_domain_id

MATCHING_S, MISMATCHED_S = 4.0, 5.0
MESSAGE = "no prediction matches a measurement stamp"


def _rows(base_ns: int) -> list[list[tuple[int, float]]]:
    rows = []
    for k in range(round((MATCHING_S + MISMATCHED_S) * 1000)):
        phase = math.sin(2 * math.pi * 5.0 * k / 1000.0)
        values = (1.6e6 + 4e5 * phase, 3e3 + 1e3 * phase, -1e-4 + 2e-5 * phase)
        stamp = base_ns + k * MS
        shifted = stamp + (MS // 2 if k >= MATCHING_S * 1000 else 0)
        rows.append([*((stamp, v) for v in values), *((shifted, v) for v in values)])
    return rows


FLAG_WAIT_S = 15.0
"""Longest wait after the last sample for the node's ERROR (s): a deadline, not a latency."""


def _flagged_names(collector: Collector) -> set[str]:
    return {
        status.name
        for _, array in list(collector.arrays[common.DIAGNOSTICS_TOPIC])
        for status in array.status
        if status.name.startswith("comparator: ")
        and status.level == bytes([common.ERROR])
        and MESSAGE in status.message
    }


@pytest.fixture(scope="module")
def no_match_run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out: Path = tmp_path_factory.mktemp("no_match")
    base_ns = (time.time_ns() // MS) * MS
    with ros_domain(unique_domain_id()) as env:
        collector = Collector([], [common.DIAGNOSTICS_TOPIC])
        source = SamplePublisher(*MEASURED_OUTPUTS, *PREDICTED_OUTPUTS)
        node = start_node("comparator", {"window_cycles": 5}, env, out / "logs")
        try:
            assert source.wait_for_subscribers(1), "the comparator did not subscribe"
            started = time.monotonic_ns()
            source.publish_rows(_rows(base_ns))
            ended = time.monotonic_ns()
            # On a busy runner the node takes samples late and in bursts: wait (generously)
            # until it has said so on every channel, rather than a fixed time.
            deadline = time.monotonic() + FLAG_WAIT_S
            while time.monotonic() < deadline and len(_flagged_names(collector)) < 4:
                time.sleep(0.1)
            time.sleep(0.5)
        finally:
            code = stop_node(node)
            source.close()
            collector.close()
    statuses = [
        (common.stamp_ns(array), status)
        for _, array in collector.arrays[common.DIAGNOSTICS_TOPIC]
        for status in array.status
        if status.name.startswith("comparator: ")
    ]
    wall_offset = time.time_ns() - time.monotonic_ns()
    return {
        "statuses": statuses,
        "mismatch_from_ns": started + wall_offset + round(MATCHING_S * 1e9),
        "mismatched_stamps_from_ns": base_ns + round(MATCHING_S * 1e9),
        "ended_ns": ended + wall_offset,
        "exit": code,
    }


def test_predictions_that_never_match_are_an_error_after_a_few_seconds(
    no_match_run: dict[str, Any],
) -> None:
    assert no_match_run["exit"] == 0
    start = no_match_run["mismatch_from_ns"]
    flagged = [
        (stamp, status)
        for stamp, status in no_match_run["statuses"]
        if status.level == bytes([common.ERROR]) and MESSAGE in status.message
    ]
    names = {status.name for _, status in flagged}
    assert names == {f"comparator: {c}" for c in ("summary", "p_b", "F_k", "x_c")}
    first = min(stamp for stamp, _ in flagged)
    # after the mismatch began (NO_MATCH_S of the node's own clock: on a busy runner the node
    # takes samples late and in bursts, so this process's clock bounds it only loosely)
    assert first >= start + 1e9
    channel_messages = [s.message for _, s in flagged if s.name != "comparator: summary"]
    seconds = [float(m.split(" for ")[1].split(" s ")[0]) for m in channel_messages]
    assert min(seconds) >= NO_MATCH_S  # the node's own clock: a few seconds without a match
    # soon after the mismatch (the node lags the publisher on a busy runner: a deadline)
    assert first <= no_match_run["ended_ns"] + (FLAG_WAIT_S + 1.0) * 1e9


def _cycle_end_ns(status: Any) -> int:
    return next(int(kv.value) for kv in status.values if kv.key == "cycle_end_stamp_ns")


def test_matching_stamps_are_not_flagged(no_match_run: dict[str, Any]) -> None:
    # The cycles the node scored on samples stamped before the mismatch (by the data's stamps,
    # not by when they were published: on a busy runner the node scores them late).
    scored = [
        status
        for _, status in no_match_run["statuses"]
        if status.name != "comparator: summary"
        and 0 <= _cycle_end_ns(status) <= no_match_run["mismatched_stamps_from_ns"]
    ]
    assert scored, "no cycle of the matching samples was scored"
    assert not any(MESSAGE in status.message for status in scored)
    assert all(status.level != bytes([common.ERROR]) for status in scored)
