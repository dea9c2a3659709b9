"""CPU of the four chain nodes at 1 kHz, before and after a change, in one run.

Each variant runs the chain (``pressure_source`` looping ``bags/one_washer_lti`` at 1 kHz ->
``caliper_model`` -> ``comparator``, and the ``recorder``), each node its own process on
loopback DDS, for ``--seconds`` after an 8 s start-up, and reads each node's CPU time from
``/proc`` (user + system, % of one core). The variants run one after the other, alternating
(before, after, before, after, ... ``--rounds`` times), so the machine's other load falls on
both alike; the figures are the mean over rounds. Losses are checked too (the recorder's MCAP
against what the source published and the model predicted).

Variants:

* ``before``: as on main before this change: rmw's own transports for
  ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` (``BRAKE_HIL_DDS_PROFILE=off``), the source's
  and the model's loops spinning the last 150 us before each deadline.
* ``after``: the project's loopback profile (one UDPv4 transport on 127.0.0.1) and the loops
  sleeping to their deadlines (``spin_margin_us`` 0).

Run from the checkout::

    .venv/bin/python benchmarks/bench_cpu.py --seconds 60 --rounds 1
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
import os
from pathlib import Path
import shutil
import sys
import time
from typing import Any

PROJECT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(PROJECT))

from brake_hil.app.chain import (  # noqa: E402
    NodeProcess,
    ros_environment,
    start_node,
    stop_node,
)
from brake_hil.io.recording_reader import list_topics  # noqa: E402
from brake_hil.topics import MASTER_CYLINDER_PRESSURE, PREDICTED_OUTPUTS  # noqa: E402

RECORDING = PROJECT / "bags" / "one_washer_lti"
MODEL = PROJECT / "config" / "rig_default.yaml"
NODES = ("pressure_source", "caliper_model", "comparator", "recorder")

VARIANTS: dict[str, dict[str, Any]] = {
    "before": {"env": {"BRAKE_HIL_DDS_PROFILE": "off"}, "loops": {"spin_margin_us": 150}},
    "after": {"env": {}, "loops": {"spin_margin_us": 0}},
}


def run_variant(name: str, seconds: float, out: Path) -> dict[str, Any]:
    """One chain run of a variant; CPU % per node and what the recorder lost."""
    variant = VARIANTS[name]
    saved = {key: os.environ.get(key) for key in variant["env"]}
    os.environ.update(variant["env"])
    try:
        env = ros_environment()
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
    if out.exists():
        shutil.rmtree(out)
    logs = out / "logs"
    loops: Mapping[str, Any] = variant["loops"]
    nodes: list[NodeProcess] = [
        start_node("recorder", {"output_dir": str(out), "bag_name": "bag"}, env, logs),
        start_node("comparator", {}, env, logs),
        start_node(
            "caliper_model",
            {
                "model_file": str(MODEL),
                "mean_pressure": 1.55e6,
                "statistics_file": str(out / "caliper_model.json"),
                "wait_for_subscribers": 2,
                **loops,
            },
            env,
            logs,
        ),
    ]
    source = start_node(
        "pressure_source",
        {
            "recording": str(RECORDING),
            "loop": True,
            "wait_for_subscribers": 2,
            "wait_timeout": 30.0,
            "start_delay": 1.0,
            "statistics_file": str(out / "pressure_source.json"),
            **loops,
        },
        env,
        logs,
    )
    nodes.append(source)
    try:
        time.sleep(8.0)
        start = {n.name: n.cpu_seconds() or 0.0 for n in nodes}
        began = time.monotonic()
        time.sleep(seconds)
        elapsed = time.monotonic() - began
        end = {n.name: n.cpu_seconds() or 0.0 for n in nodes}
    finally:
        stop_node(source)
        time.sleep(1.0)
        for node in reversed(nodes[:-1]):
            stop_node(node)
    cpu = {n: 100.0 * (end[n] - start[n]) / elapsed for n in NODES}
    import json

    published = json.loads((out / "pressure_source.json").read_text())["published"]
    predicted = json.loads((out / "caliper_model.json").read_text())["counters"]["predictions"]
    counts = {t.name: t.message_count for t in list_topics(out / "bag")}
    lost = (published - counts.get(MASTER_CYLINDER_PRESSURE.name, 0)) + (
        predicted - counts.get(PREDICTED_OUTPUTS[0].name, 0)
    )
    return {"cpu": cpu, "published": published, "unpredicted": published - predicted, "lost": lost}


def main() -> int:
    """Run the variants alternately; print CPU per node."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--out", type=Path, default=PROJECT / "out" / "bench_cpu")
    args = parser.parse_args()
    results: dict[str, list[dict[str, Any]]] = {name: [] for name in VARIANTS}
    for round_ in range(args.rounds):
        for name in VARIANTS:
            result = run_variant(name, args.seconds, args.out / f"{name}_{round_}")
            results[name].append(result)
            cpu = ", ".join(f"{n} {v:.0f}" for n, v in result["cpu"].items())
            print(
                f"round {round_ + 1} {name:6s}: CPU % {cpu}, total "
                f"{sum(result['cpu'].values()):.0f}; {result['published']} published, "
                f"{result['unpredicted']} unpredicted, {result['lost']} lost by the recorder; "
                f"load {os.getloadavg()[0]:.1f}",
                flush=True,
            )
    print(f"\nmean over {args.rounds} round(s) of {args.seconds:g} s, CPU % of one core:")
    print(f"{'variant':8s}" + "".join(f"{n:>17s}" for n in NODES) + f"{'total':>8s}")
    for name, runs in results.items():
        means = {n: sum(r["cpu"][n] for r in runs) / len(runs) for n in NODES}
        print(
            f"{name:8s}"
            + "".join(f"{means[n]:17.0f}" for n in NODES)
            + f"{sum(means.values()):8.0f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
