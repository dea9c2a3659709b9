"""caliper_model under faulty input, as its own process: NaN, an absurd value, stamps back.

A publisher in the test process sends ``p_i`` at 1 kHz: good samples, then a NaN and an
infinity (not stepped, counted, ERROR naming the stamp; the model goes on from its last good
state), then 40 samples of 1.79e308 Pa (finite, but the model's outputs overflow: not
published, counted, restart from the equilibrium), then ten samples stamped again with
earlier stamps (dropped, WARN: never two predictions with one stamp). What the node
published is checked against the same samples stepped here, and its counts and statuses.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
import time
from typing import Any

import numpy as np
import pytest

from brake_hil.app.chain import start_node, stop_node
from brake_hil.live.model_file import load_model
from brake_hil.nodes import common
from brake_hil.runtime import CatchUpRunner, Sample
from brake_hil.topics import MASTER_CYLINDER_PRESSURE, PREDICTED_OUTPUTS
from test.conftest import CONFIG
from test.nodes.faults import MS, SamplePublisher
from test.nodes.harness import Collector, ros_domain, unique_domain_id
from test.waiting import wait_until, wait_until_still

RIG = CONFIG / "rig_default.yaml"
MEAN_PRESSURE = 1.6e6
PREDICTED_NAMES = [spec.name for spec in PREDICTED_OUTPUTS]
NAN_AT, INF_AT = 500, 501  # sample indices of the non-finite inputs
HUGE = range(1000, 1040)  # indices of the 1.79e308 Pa samples
BACK_AT, BACK_FROM, BACKWARDS = 1340, 1300, 10  # 10 samples re-stamped 1300..1309
TOTAL = 1540


def _inputs(base_ns: int) -> list[tuple[int, float]]:
    samples = []
    back = 0
    for k in range(TOTAL):
        value = MEAN_PRESSURE + 4e5 * math.sin(2 * math.pi * 5.0 * k / 1000.0)
        stamp = base_ns + k * MS
        if k == NAN_AT:
            value = math.nan
        elif k == INF_AT:
            value = math.inf
        elif k in HUGE:
            value = 1.79e308
        elif BACK_AT <= k < BACK_AT + BACKWARDS:
            stamp = base_ns + (BACK_FROM + back) * MS
            back += 1
        if k >= BACK_AT + BACKWARDS:
            stamp = base_ns + (k - BACKWARDS) * MS  # the source goes on after the last good stamp
        samples.append((stamp, value))
    return samples


def _reported_backwards(collector: Collector) -> bool:
    """Whether an input status counting every backward stamp has come."""
    return any(
        status.name == "caliper_model: input"
        and f"{BACKWARDS} samples stamped at or before" in status.message
        for _, array in collector.arrays[common.DIAGNOSTICS_TOPIC]
        for status in array.status
    )


@pytest.fixture(scope="module")
def faulty_run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out: Path = tmp_path_factory.mktemp("model_faults")
    base_ns = (time.time_ns() // MS) * MS
    samples = _inputs(base_ns)
    with ros_domain(unique_domain_id()) as env:
        collector = Collector(PREDICTED_OUTPUTS, [common.DIAGNOSTICS_TOPIC])
        source = SamplePublisher(MASTER_CYLINDER_PRESSURE)
        parameters = {
            "model_file": str(RIG),
            "mean_pressure": MEAN_PRESSURE,
            "input_silent_ms": 2000.0,
            "input_late_ms": 1000.0,
            "statistics_file": str(out / "caliper_model.json"),
        }
        node = start_node("caliper_model", parameters, env, out / "logs")
        try:
            assert source.wait_for_subscribers(1), "the model did not subscribe"
            assert collector.wait_for_publishers(PREDICTED_NAMES), "the model did not come up"
            time.sleep(0.5)
            source.publish(samples)
            # the model steps the last samples and reports them; a busy runner's node and
            # collector lag: wait (generously) for its predictions to stop coming and for a
            # status counting every backward stamp, not a fixed time
            wait_until(lambda: collector.samples[PREDICTED_NAMES[0]], 30.0)
            wait_until_still(lambda: len(collector.samples[PREDICTED_NAMES[0]]), 1.0, 30.0)
            wait_until(lambda: _reported_backwards(collector), 30.0)
        finally:
            code = stop_node(node)
            source.close()
            collector.close()
    statistics = json.loads((out / "caliper_model.json").read_text())
    statuses = [
        (status.name, status.level[0], status.message, common.status_values(status))
        for _, array in collector.arrays[common.DIAGNOSTICS_TOPIC]
        for status in array.status
    ]
    return {
        "samples": samples,
        "predicted": {name: collector.samples[name] for name in PREDICTED_NAMES},
        "counters": statistics["counters"],
        "statuses": statuses,
        "exit": code,
        "log": (out / "logs" / "caliper_model.log").read_text(errors="replace"),
    }


def test_the_node_survives_and_exits_cleanly(faulty_run: dict[str, Any]) -> None:
    assert faulty_run["exit"] == 0, faulty_run["log"]


def test_nonfinite_inputs_are_counted_not_stepped_and_reported_as_error(
    faulty_run: dict[str, Any],
) -> None:
    counters = faulty_run["counters"]
    assert counters["samples"] == TOTAL
    assert counters["nonfinite_inputs"] == 2
    inf_stamp = faulty_run["samples"][INF_AT][0]
    named = [
        s
        for s in faulty_run["statuses"]
        if s[0] == "caliper_model: input" and s[1] == common.ERROR and "non-finite p_i" in s[2]
    ]
    assert named, "no ERROR naming the non-finite p_i"
    assert int(named[-1][3]["last_nonfinite_stamp_ns"]) == inf_stamp
    assert f"{inf_stamp / 1e9:.3f}" in named[-1][2]
    stamps = {stamp for stamp, _, _ in faulty_run["predicted"][PREDICTED_NAMES[0]]}
    assert faulty_run["samples"][NAN_AT][0] not in stamps
    assert faulty_run["samples"][INF_AT][0] not in stamps


def test_a_nonfinite_state_restarts_from_the_equilibrium_and_is_reported(
    faulty_run: dict[str, Any],
) -> None:
    counters = faulty_run["counters"]
    assert counters["nonfinite_states"] >= 1 and counters["state_resets"] >= 1
    models = [s for s in faulty_run["statuses"] if s[0] == "caliper_model: model"]
    assert any(s[1] == common.ERROR and "non-finite model state" in s[2] for s in models)
    assert int(models[-1][3]["nonfinite_states"]) == counters["nonfinite_states"]
    for name in PREDICTED_NAMES:
        assert all(math.isfinite(value) for _, value, _ in faulty_run["predicted"][name]), name


def test_stamps_going_backwards_warn_and_never_give_two_predictions_one_stamp(
    faulty_run: dict[str, Any],
) -> None:
    counters = faulty_run["counters"]
    assert counters["stamps_backwards"] == BACKWARDS
    for name in PREDICTED_NAMES:
        stamps = [stamp for stamp, _, _ in faulty_run["predicted"][name]]
        assert len(stamps) == len(set(stamps)), name
    inputs = [s for s in faulty_run["statuses"] if s[0] == "caliper_model: input"]
    last = inputs[-1]
    assert last[1] >= common.WARN and f"{BACKWARDS} samples stamped at or before" in last[2]


def test_published_predictions_are_the_model_stepped_from_its_last_good_state(
    faulty_run: dict[str, Any],
) -> None:
    counters = faulty_run["counters"]
    reference = CatchUpRunner(
        load_model(RIG, MEAN_PRESSURE).stepper(),
        restart=load_model(RIG, MEAN_PRESSURE).stepper,
    )
    for stamp, value in faulty_run["samples"]:
        reference.push(Sample(stamp, value, 0))
    with np.errstate(over="ignore", invalid="ignore"):
        expected = reference.tick(0).predictions
    published = sorted(faulty_run["predicted"][PREDICTED_NAMES[0]])
    expected_count = TOTAL - 2 - BACKWARDS - counters["nonfinite_states"]
    assert counters["predictions"] == len(published) == len(expected) == expected_count
    assert [s[0] for s in published] == [p.stamp_ns for p in expected]
    for index, name in enumerate(PREDICTED_NAMES):
        live = np.array([v for _, v, _ in sorted(faulty_run["predicted"][name])])
        offline = np.array([p[index + 1] for p in expected])
        assert np.array_equal(live, offline), name
    # The sample after the NaN and the inf is stepped from the state before them: a plain
    # stepper fed the good samples only gives the same prediction.
    plain = load_model(RIG, MEAN_PRESSURE).stepper()
    for _, value in faulty_run["samples"][: INF_AT + 2]:
        if math.isfinite(value):
            outputs = plain.step(value)
    after = faulty_run["samples"][INF_AT + 1][0]
    live_after = next(v for s, v, _ in published if s == after)
    assert live_after == outputs[0]
