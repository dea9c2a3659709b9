"""The node chain as separate processes: source replaying a bag -> caliper model -> comparator.

Each node is its own ``python -m brake_hil.nodes.<name>`` process on loopback with a domain id
of its own; a real rclpy node in the test process collects what they publish. Four seconds of
``bags/one_washer_lti`` are replayed from 8 s (the second steady segment); the nodes are then
stopped with SIGINT. A second run adds the recorder and reads its MCAP with an independent
reader (``mcap`` + ``mcap_ros2``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
import json
from operator import attrgetter
from pathlib import Path
import re
import time
from typing import Any

import numpy as np
import pytest

from brake_hil.app.chain import NodeProcess, node_available, start_node, stop_node
from brake_hil.io.recording_reader import read_recording
from brake_hil.live.model_file import load_model
from brake_hil.nodes import common
from brake_hil.topics import MASTER_CYLINDER_PRESSURE, MEASURED_OUTPUTS, PREDICTED_OUTPUTS
from test.conftest import CONFIG, PROJECT
from test.nodes.harness import Collector, ros_domain, unique_domain_id

BAG = PROJECT / "bags" / "one_washer_lti"
RIG = CONFIG / "rig_default.yaml"
START_S, DURATION_S = 8.0, 4.0  # the replayed span of the bag (s)
MEAN_PRESSURE = 1.6e6  # Pa, the model's operating point (the segment's mean p_i)
SILENT_MS = 8.0  # the model's input_silent_ms in these runs
PREDICTED_NAMES = [spec.name for spec in PREDICTED_OUTPUTS]


@dataclass
class ChainRun:
    """What one run of the chain left behind."""

    collector: Collector
    out: Path
    exit_codes: dict[str, int] = field(default_factory=dict)
    source_ended_ns: int = 0  # wall clock when the source process had exited
    bag: Path | None = None

    def samples(self, topic: str) -> list[tuple[int, float, int]]:
        return self.collector.samples[topic]

    def statuses(self, topic: str, name: str) -> list[tuple[int, Any, Any]]:
        """``(receive_ns, array, status)`` of every status called ``name`` on ``topic``."""
        return [
            (received, array, status)
            for received, array in self.collector.arrays[topic]
            for status in array.status
            if status.name == name
        ]


def _run_chain(out: Path, with_recorder: bool) -> ChainRun:
    with ros_domain(unique_domain_id()) as env:
        collector = Collector(
            [MASTER_CYLINDER_PRESSURE, *PREDICTED_OUTPUTS],
            [common.DIAGNOSTICS_TOPIC, common.COMPARISON_TOPIC],
        )
        run = ChainRun(collector, out)
        logs = out / "logs"
        nodes: list[NodeProcess] = []
        try:
            extra = 0
            if with_recorder:
                extra = 1
                recorder = {"output_dir": str(out), "bag_name": "run", "discovery_interval_s": 0.1}
                nodes.append(start_node("recorder", recorder, env, logs))
            nodes.append(
                start_node(
                    "comparator",
                    {"window_cycles": 5, "summary_file": str(out / "comparator.json")},
                    env,
                    logs,
                )
            )
            model = {
                "model_file": str(RIG),
                "mean_pressure": MEAN_PRESSURE,
                "input_late_ms": 3.0,
                "input_silent_ms": SILENT_MS,
                "statistics_file": str(out / "caliper_model.json"),
            }
            nodes.append(start_node("caliper_model", model, env, logs))
            assert collector.wait_for_publishers(PREDICTED_NAMES), "the model did not come up"
            waits = [f"{MASTER_CYLINDER_PRESSURE.name}:{2 + extra}"]
            waits += [f"{spec.name}:{1 + extra}" for spec in MEASURED_OUTPUTS]
            waits += [f"{name}:{2 + extra}" for name in PREDICTED_NAMES]
            source = {
                "recording": str(BAG),
                "start_offset": START_S,
                "duration": DURATION_S,
                "exit_at_end": True,
                "wait_for_topics": waits,
                "wait_timeout": 30.0,
                "start_delay": 0.5,
            }
            player = start_node("pressure_source", source, env, logs)
            nodes.append(player)
            player.process.wait(60)
            run.source_ended_ns = time.time_ns()
            time.sleep(0.5)  # the model drains and reports the silent input
        finally:
            for node in reversed(nodes):
                run.exit_codes[node.name] = stop_node(node, timeout_s=10.0)
            collector.close()
    if with_recorder and (out / "run" / "metadata.yaml").is_file():
        run.bag = out / "run"
    return run


@pytest.fixture(scope="module")
def live_run(tmp_path_factory: pytest.TempPathFactory) -> ChainRun:
    return _run_chain(tmp_path_factory.mktemp("chain"), with_recorder=False)


@pytest.fixture(scope="module")
def replayed() -> Any:
    """The replayed span of the bag: stamps (ns) and p_i (Pa)."""
    recording = read_recording(BAG)
    keep = (recording.time >= START_S - 1e-9) & (recording.time < START_S + DURATION_S - 1e-9)
    stamps = recording.start_stamp_ns + (recording.time[keep] * 1e9).round().astype(np.int64)
    return stamps, recording.master_cylinder_pressure[keep]


def _series(samples: list[tuple[int, float, int]]) -> tuple[Any, Any]:
    ordered = sorted(samples)
    return np.array([s[0] for s in ordered]), np.array([s[1] for s in ordered])


def test_nodes_exit_cleanly_on_sigint(live_run: ChainRun) -> None:
    assert live_run.exit_codes == {"pressure_source": 0, "caliper_model": 0, "comparator": 0}


def test_source_replays_the_chosen_span_paced_and_shifted_to_now(
    live_run: ChainRun, replayed: Any
) -> None:
    recorded_stamps, recorded_values = replayed
    stamps, values = _series(live_run.samples(MASTER_CYLINDER_PRESSURE.name))
    assert stamps.size == recorded_stamps.size == round(DURATION_S * 1000)
    np.testing.assert_array_equal(values, recorded_values)
    np.testing.assert_array_equal(np.diff(stamps), np.diff(recorded_stamps))  # spacing kept
    arrivals = np.array([s[2] for s in sorted(live_run.samples(MASTER_CYLINDER_PRESSURE.name))])
    # Stamped with the wall clock, not 2023; paced at real time. Bounds that hold on a busy
    # 2-core runner, where this process receives up to a few seconds late and in bursts.
    assert abs(np.median(arrivals - stamps)) < 10e9
    assert (stamps[-1] - stamps[0]) / 1e9 == pytest.approx(DURATION_S, abs=0.002)
    assert (arrivals[-1] - arrivals[0]) / 1e9 > 0.5 * DURATION_S


def test_every_input_sample_gets_exactly_one_prediction_with_its_stamp(
    live_run: ChainRun,
) -> None:
    inputs = [s[0] for s in live_run.samples(MASTER_CYLINDER_PRESSURE.name)]
    for name in PREDICTED_NAMES:
        stamps = [s[0] for s in live_run.samples(name)]
        assert len(stamps) == len(inputs), name
        assert sorted(stamps) == sorted(inputs), name
    statistics = json.loads((live_run.out / "caliper_model.json").read_text())
    counters = statistics["counters"]
    assert counters["samples"] == counters["predictions"] == len(inputs)
    assert counters["missing_samples"] == counters["stamps_backwards"] == counters["held"] == 0


def test_live_predictions_equal_the_batch_model_on_the_same_raw_samples(
    live_run: ChainRun,
) -> None:
    _, pressure = _series(live_run.samples(MASTER_CYLINDER_PRESSURE.name))
    batch = load_model(RIG, MEAN_PRESSURE).batch(pressure)
    for name, offline in zip(PREDICTED_NAMES, batch):
        _, live = _series(live_run.samples(name))
        assert np.max(np.abs(live - offline)) <= 1e-9 * np.ptp(offline), name


def test_model_reports_its_timing_on_diagnostics(live_run: ChainRun) -> None:
    loops = live_run.statuses(common.DIAGNOSTICS_TOPIC, "caliper_model: loop")
    assert loops
    values = [common.status_values(status) for _, _, status in loops]
    measured = [v for v in values if "latency_p99_us" in v]
    assert measured, "no report with input-to-prediction latency"
    for key in ("period_error_median_us", "period_error_p99_us", "step_time_p99_us", "overruns"):
        assert key in measured[-1]
    assert int(values[-1]["ticks"]) > 3000


def test_model_reports_the_silent_input_rather_than_inventing_samples(
    live_run: ChainRun,
) -> None:
    last_input = max(s[2] for s in live_run.samples(MASTER_CYLINDER_PRESSURE.name))
    inputs = live_run.statuses(common.DIAGNOSTICS_TOPIC, "caliper_model: input")
    silent = [
        (received, status)
        for received, _, status in inputs
        if received > last_input and common.status_values(status)["state"] == "silent"
    ]
    assert silent, "the silent input was not reported"
    received, status = silent[0]
    assert status.level == bytes([common.ERROR])
    assert received - last_input < (SILENT_MS + 5000.0) * 1e6  # reported (busy runner: late)
    # Nothing invented once silent: no prediction stamped after the last input, one per input.
    # (By stamps, not by arrival: on a busy runner this process receives a topic's tail late.)
    input_stamps = [s[0] for s in live_run.samples(MASTER_CYLINDER_PRESSURE.name)]
    for name in PREDICTED_NAMES:
        stamps = [s[0] for s in live_run.samples(name)]
        assert max(stamps) == max(input_stamps), name
        assert len(stamps) == len(input_stamps), name


def test_comparator_scores_each_cycle_with_levels(live_run: ChainRun) -> None:
    channels = {}
    for channel in ("p_b", "F_k", "x_c"):
        statuses = live_run.statuses(common.COMPARISON_TOPIC, f"comparator: {channel}")
        scored = [(status, common.status_values(status)) for _, _, status in statuses]
        channels[channel] = [(s, v) for s, v in scored if "window_nrmse" in v]
        assert channels[channel], f"no scored cycle for {channel}"
    status, values = channels["p_b"][-1]
    assert 100.0 < float(values["window_ptp_ratio_pct"]) < 110.0  # compare's 104.5 %
    assert status.level == bytes([common.OK])
    status, values = channels["x_c"][-1]
    assert float(values["window_nrmse"]) > 0.15  # the nominal rig's caliper stiffness is off
    assert status.level == bytes([common.WARN])
    summary = json.loads((live_run.out / "comparator.json").read_text())
    assert summary["metrics"]["p_b"]["cycles"] >= 3


# --------------------------------------------------------------------------- recorder


@pytest.fixture(scope="module")
def recorded_run(tmp_path_factory: pytest.TempPathFactory) -> ChainRun:
    if not node_available("recorder"):
        pytest.skip("brake_hil.nodes.recorder is not available")
    return _run_chain(tmp_path_factory.mktemp("recorded"), with_recorder=True)


def _mcap_messages(bag: Path) -> dict[str, list[Any]]:
    """Decoded messages per topic, read with mcap and mcap_ros2 (not brake_hil's reader)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    messages: dict[str, list[Any]] = {}
    for path in sorted(bag.glob("*.mcap")):
        with path.open("rb") as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            for _, channel, _, decoded in reader.iter_decoded_messages():
                messages.setdefault(channel.topic, []).append(decoded)
    return messages


def test_recorded_mcap_holds_every_sample_and_prediction(recorded_run: ChainRun) -> None:
    assert recorded_run.bag is not None, "the recorder wrote no rosbag2 directory"
    messages = _mcap_messages(recorded_run.bag)
    inputs = messages.get(MASTER_CYLINDER_PRESSURE.name, [])
    counts = {topic: len(found) for topic, found in messages.items()}
    collected = len(recorded_run.samples(MASTER_CYLINDER_PRESSURE.name))
    detail = f"recorded {counts}, collected {collected} inputs, exits {recorded_run.exit_codes}"
    assert len(inputs) == collected == round(DURATION_S * 1000), detail

    def stamp(message: Any) -> int:
        return int(message.header.stamp.sec) * 1_000_000_000 + int(message.header.stamp.nanosec)

    ordered = sorted(inputs, key=stamp)
    pressure = np.array([m.fluid_pressure for m in ordered])
    batch = load_model(RIG, MEAN_PRESSURE).batch(pressure)
    fields = (
        lambda m: m.fluid_pressure,
        lambda m: m.wrench.force.z,
        lambda m: m.vector.z,
    )
    for name, read, offline in zip(PREDICTED_NAMES, fields, batch):
        predicted = sorted(messages.get(name, []), key=stamp)
        assert [stamp(m) for m in predicted] == [stamp(m) for m in ordered], f"{name}: {detail}"
        live = np.array([read(m) for m in predicted])
        assert np.max(np.abs(live - offline)) <= 1e-9 * np.ptp(offline), name


LAYOUT = PROJECT / "config" / "foxglove_layout.json"


def _layout_references(layout: dict[str, Any]) -> tuple[set[str], set[str], set[str]]:
    """Topics, ``topic.field`` paths and status names the Foxglove layout's panels use."""
    topics, fields, names = set(), set(), set()
    for panel in layout["configById"].values():
        values = [p["value"] for p in panel.get("paths", [])]
        values += [panel[k] for k in ("topicPath", "topicToRender") if k in panel]
        for value in values:
            topic, _, rest = value.partition(".")
            topics.add(topic)
            names.update(re.findall(r'name=="([^"]+)"', rest))
            if rest and "{" not in rest:
                fields.add(value)
    return topics, fields, names


def test_the_foxglove_layout_shows_topics_fields_and_statuses_of_a_real_recording(
    recorded_run: ChainRun,
) -> None:
    assert recorded_run.bag is not None
    layout = json.loads(LAYOUT.read_text())
    topics, fields, names = _layout_references(layout)
    messages = _mcap_messages(recorded_run.bag)
    assert topics <= set(messages), topics - set(messages)
    for spec in (*MEASURED_OUTPUTS, *PREDICTED_OUTPUTS):  # measured vs predicted, each channel
        assert f"{spec.name}.{spec.field}" in fields
    for path in fields:  # every plotted field holds a number in the recording
        topic, _, field = path.partition(".")
        assert isinstance(attrgetter(field)(messages[topic][0]), float), path
    recorded_names = {s.name for m in messages["/brake/comparison"] for s in m.status}
    assert names and names <= recorded_names, names - recorded_names
    assert "/diagnostics" in topics
    # Every panel the mosaic places exists, and every panel is placed.
    placed = set(re.findall(r'"([A-Za-z]+![^"]+)"', json.dumps(layout["layout"])))
    assert placed == set(layout["configById"])
