"""The pressure source's CAN DAQ under faults, across processes, over real slcan on a pty.

This test plays the rig's DAQ on an slcan pseudo-terminal (:class:`SlcanPty`); the source node
(its own process) reads it. Three phases: 300 good acquisitions; then the DAQ freezes and
repeats its last acquisition's frames 1 000 times (a counter that does not advance: STALE,
nothing published as fresh); then ten stops: 50 acquisitions, 500 ms of silence, each stop
reported STALE by the deadline the last frame armed, before the next burst.
"""

from __future__ import annotations

import json
from pathlib import Path
import time
from typing import Any

import pytest

from brake_hil.app.chain import stop_node
from brake_hil.io.can_daq import RigFrameCodec, SlcanPty
from brake_hil.nodes import common
from brake_hil.topics import MASTER_CYLINDER_PRESSURE as P_I
from test.nodes.faults import start_can_source
from test.nodes.harness import Collector, ros_domain, unique_domain_id
from test.waiting import wait_until

pytest.importorskip("serial", reason="python-can's slcan interface needs pyserial")

STALE_AFTER_MS = 5.0
GOOD, FROZEN, STOPS, BURST, SILENCE_S = 300, 1000, 10, 50, 0.5


def _send(adapter: SlcanPty, frames_per_tick: list[list[Any]]) -> tuple[int, int]:
    """Send each tick's frames 1 ms apart; wall-clock ns of the first and the last tick."""
    start = time.monotonic_ns()
    first = time.time_ns()
    for k, frames in enumerate(frames_per_tick):
        while time.monotonic_ns() < start + k * 1_000_000:
            time.sleep(0.0002)
        assert adapter.send(frames, wait_s=10.0) == len(frames)  # held while the reader lags
    return first, time.time_ns()


def _acquisitions(codec: RigFrameCodec, first: int, count: int) -> list[list[Any]]:
    return [
        codec.encode(first + k, {"p_i": 1.0e6 + 1e3 * k, "p_b": 0.9e6, "F_k": 1e3, "x_c": 0.0})
        for k in range(count)
    ]


def _daq_statuses(collector: Collector) -> list[tuple[int, Any]]:
    """``(header stamp ns, status)`` of the source's DAQ status."""
    return [
        (common.stamp_ns(array), status)
        for _, array in list(collector.arrays[common.DIAGNOSTICS_TOPIC])
        for status in array.status
        if status.name == "pressure_source: daq"
    ]


@pytest.fixture(scope="module")
def faulty_daq(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out: Path = tmp_path_factory.mktemp("daq_faults")
    link = out / "rig_can"
    codec = RigFrameCodec()
    spans: dict[str, Any] = {"stops": []}
    with ros_domain(unique_domain_id()) as env:
        collector = Collector([P_I], [common.DIAGNOSTICS_TOPIC])
        adapter = SlcanPty(link)
        source = start_can_source(
            link, env, out, STALE_AFTER_MS, statistics_file=str(out / "source.json")
        )
        try:
            deadline = time.monotonic() + 30.0
            while time.monotonic() < deadline and not _daq_statuses(collector):
                time.sleep(0.05)
            assert _daq_statuses(collector), (out / "logs" / "pressure_source.log").read_text()
            assert collector.wait_for_publishers([P_I.name])
            good = _acquisitions(codec, 0, GOOD)
            spans["good"] = _send(adapter, good)
            spans["frozen"] = _send(adapter, [good[-1]] * FROZEN)
            time.sleep(SILENCE_S)
            for stop in range(STOPS):
                burst = _acquisitions(codec, GOOD + stop * BURST, BURST)
                spans["stops"].append(_send(adapter, burst))
                time.sleep(SILENCE_S)
            # every good acquisition through (a busy runner's node and collector lag), then
            # none more
            wait_until(lambda: len(collector.samples[P_I.name]) >= GOOD + STOPS * BURST, 30.0)
            time.sleep(0.5)
        finally:
            code = stop_node(source, timeout_s=10.0)
            adapter.close()
            collector.close()
    return {
        "spans": spans,
        "samples": collector.samples[P_I.name],
        "statuses": _daq_statuses(collector),
        "summary": json.loads((out / "source.json").read_text()),
        "exit": code,
    }


def test_a_frozen_counter_publishes_nothing_and_is_stale(faulty_daq: dict[str, Any]) -> None:
    assert faulty_daq["exit"] == 0
    samples = faulty_daq["samples"]
    assert len(samples) == GOOD + STOPS * BURST  # not one of the repeats
    stamps = [s[0] for s in samples]
    assert len(set(stamps)) == len(stamps)
    daq = faulty_daq["summary"]["daq"]
    assert daq["stale_counters"] == FROZEN * 2  # two frames per acquisition
    frozen_from, frozen_to = faulty_daq["spans"]["frozen"]
    during = [
        status
        for stamp, status in faulty_daq["statuses"]
        if frozen_from < stamp < frozen_to + 100_000_000
    ]
    assert any(
        s.level == bytes([common.STALE]) and "did not advance" in s.message for s in during
    ), [s.message for s in during]


def test_each_stop_of_the_bus_is_reported_stale_before_frames_come_back(
    faulty_daq: dict[str, Any],
) -> None:
    stops = faulty_daq["spans"]["stops"]
    stale = [
        stamp for stamp, status in faulty_daq["statuses"] if status.level == bytes([common.STALE])
    ]
    # each stop reported: a STALE after each stop's last frame (the node's reading lags on a
    # busy runner, so not bounded by the next burst here; benchmarks/bench_stale.py times it)
    for index, (_, last_frame) in enumerate(stops):
        assert any(stamp > last_frame - 5_000_000 for stamp in stale), index
    assert len(stale) >= 1 + STOPS
    reports = faulty_daq["summary"]["daq"]["stale_reports_ms"]
    # the frozen span and each stop at least (a sender hiccup over 5 ms is a stop too), never
    # before the deadline
    assert len(reports) >= 1 + STOPS, reports
    assert all(delay >= STALE_AFTER_MS for delay in reports), reports
    print("stale reported after the last good frame (ms):", [f"{d:.2f}" for d in reports])
