"""CPU of the four chain nodes at 1 kHz, before and after a change, in one run.

Each variant runs the chain (``pressure_source`` looping ``bags/one_washer_lti`` at 1 kHz ->
``caliper_model`` -> ``comparator``, and the ``recorder``), each node its own process on
loopback DDS, for ``--seconds`` after an 8 s start-up, and reads each node's CPU time from
``/proc`` (user + system, % of one core). The variants run one after the other, alternating
(before, after, before, after, ... ``--rounds`` times), so the machine's other load falls on
both alike; the figures are the mean over rounds. Losses are checked too (the recorder's MCAP
against what the source published and the model predicted).

Variants:

* ``before``: the alternative to the loopback profile: rmw's own transports for
  ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` (``BRAKE_HIL_DDS_PROFILE=off``), the source's
  and the model's loops spinning the last 150 us before each deadline.
* ``after``: the project's loopback profile (one UDPv4 transport on 127.0.0.1) and the loops
  sleeping to their deadlines (``spin_margin_us`` 0).
* ``model_apart``: as ``after``, the source, comparator and recorder in one process (the
  container) and the caliper model in its own.
* ``two_process``: as ``after``, the source and the model in one process, the comparator and
  the recorder in another.
* ``paired``: as ``two_process``, the model stepped on the source's thread right after each
  sample (``paired_with_source``: one thread for the two 1 kHz loops).
* ``one_process``: as ``after``, the four nodes in one process
  (``python -m brake_hil.nodes.container``: one rclpy context, one DDS participant, Fast DDS
  delivering inside the process). The process's CPU is the total; per node, the CPU of each
  node's own threads (``/proc/PID/task``: the container names them ``model-loop``,
  ``comparator-loop``, ``source-worker``, ``source-executor``, ``recorder-loop``); the rest
  (the middleware's threads, the main thread) is ``shared``.

``--variants`` picks which (default ``before,after``); ``--one-process`` is
``--variants after,one_process``. Each line also gives the model's timing (its statistics
file: period error p99, input arrival -> prediction published p99).

Run from the checkout::

    .venv/bin/python benchmarks/bench_cpu.py --seconds 60 --rounds 1
    .venv/bin/python benchmarks/bench_cpu.py --seconds 60 --rounds 1 --one-process
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
import json
import os
from pathlib import Path
import shutil
import sys
import time
from typing import Any

PROJECT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(PROJECT))

from brake_hil.app.chain import (  # noqa: E402
    CONTAINER_STOP_S,
    ros_environment,
    start_layout,
    stop_node,
    thread_cpu_seconds,
)
from brake_hil.io.recording_reader import list_topics  # noqa: E402
from brake_hil.topics import MASTER_CYLINDER_PRESSURE, PREDICTED_OUTPUTS  # noqa: E402

RECORDING = PROJECT / "bags" / "one_washer_lti"
MODEL = PROJECT / "config" / "rig_default.yaml"
NODES = ("pressure_source", "caliper_model", "comparator", "recorder")

VARIANTS: dict[str, dict[str, Any]] = {
    "before": {"env": {"BRAKE_HIL_DDS_PROFILE": "off"}, "loops": {"spin_margin_us": 150}},
    "after": {"env": {}, "loops": {"spin_margin_us": 0}},
    "one_process": {"env": {}, "loops": {"spin_margin_us": 0}, "layout": "one-process"},
    "model_apart": {"env": {}, "loops": {"spin_margin_us": 0}, "layout": "model-apart"},
    "two_process": {"env": {}, "loops": {"spin_margin_us": 0}, "layout": "two-process"},
    "paired": {"env": {}, "loops": {"spin_margin_us": 0}, "layout": "paired"},
}
THREADS = {
    "source-worker": "pressure_source",
    "source-executor": "pressure_source",
    "model-loop": "caliper_model",
    "comparator-loop": "comparator",
    "recorder-loop": "recorder",
}
"""The container's thread names (``/proc/PID/task/*/comm``) and their nodes."""


def per_node(threads: Mapping[str, float]) -> dict[str, float]:
    """Thread figures grouped by node (:data:`THREADS`), the rest as ``shared``."""
    grouped = dict.fromkeys((*NODES, "shared"), 0.0)
    for comm, value in threads.items():
        grouped[THREADS.get(comm, "shared")] += value
    return grouped


def _plan(out: Path, loops: Mapping[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """The nodes in start order (readers first) with their parameters."""
    return [
        ("recorder", {"output_dir": str(out), "bag_name": "bag"}),
        ("comparator", {}),
        (
            "caliper_model",
            {
                "model_file": str(MODEL),
                "mean_pressure": 1.55e6,
                "statistics_file": str(out / "caliper_model.json"),
                "wait_for_subscribers": 2,
                **loops,
            },
        ),
        (
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
        ),
    ]


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
    plan = _plan(out, variant["loops"])
    layout = variant.get("layout", "processes")
    nodes = start_layout(plan, env, logs, layout)
    containers = [node for node in nodes if node.is_container]
    threads_start: dict[str, float] = {}
    threads_end: dict[str, float] = {}
    try:
        time.sleep(8.0)
        start = {n.name: n.cpu_seconds() or 0.0 for n in nodes}
        threads_start = thread_cpu_seconds(containers)
        began = time.monotonic()
        time.sleep(seconds)
        elapsed = time.monotonic() - began
        end = {n.name: n.cpu_seconds() or 0.0 for n in nodes}
        threads_end = thread_cpu_seconds(containers)
    finally:
        # The process that runs the source first (its container stops the source first):
        # the model then has no input left; then the rest, last started first.
        first = next(node for node in nodes if node.runs("pressure_source"))
        codes = {first.name: stop_node(first, CONTAINER_STOP_S if first.is_container else 10.0)}
        time.sleep(1.0)
        for node in reversed(nodes):
            if node is not first:
                codes[node.name] = stop_node(node, CONTAINER_STOP_S if node.is_container else 10.0)
    process_cpu = {n: 100.0 * (end[n] - start[n]) / elapsed for n in end}
    threads = {
        comm: 100.0 * (value - threads_start.get(comm, 0.0)) / elapsed
        for comm, value in threads_end.items()
    }
    cpu = per_node(threads) if containers else {}
    for node in nodes:
        if not node.is_container:
            cpu[node.name] = process_cpu[node.name]

    published = json.loads((out / "pressure_source.json").read_text())["published"]
    model = json.loads((out / "caliper_model.json").read_text())
    predicted = model["counters"]["predictions"]
    counts = {t.name: t.message_count for t in list_topics(out / "bag")}
    lost = (published - counts.get(MASTER_CYLINDER_PRESSURE.name, 0)) + (
        predicted - counts.get(PREDICTED_OUTPUTS[0].name, 0)
    )
    return {
        "cpu": cpu,
        "total": sum(process_cpu.values()),
        "processes": process_cpu,
        "threads": threads,
        "exit_codes": codes,
        "published": published,
        "unpredicted": published - predicted,
        "lost": lost,
        "period_error_p99_us": model["period_error"]["p99_us"],
        "latency_p99_us": model["latency"]["p99_us"],
    }


def main() -> int:
    """Run the variants alternately; print CPU per node."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--out", type=Path, default=PROJECT / "out" / "bench_cpu")
    parser.add_argument(
        "--variants",
        default="before,after",
        help=f"comma-separated, of {', '.join(VARIANTS)}",
    )
    parser.add_argument(
        "--one-process",
        action="store_true",
        help="the four-process chain against the one-process chain (--variants after,one_process)",
    )
    parser.add_argument("--json", type=Path, help="write every run's figures here too")
    args = parser.parse_args()
    names = ["after", "one_process"] if args.one_process else args.variants.split(",")
    unknown = [name for name in names if name not in VARIANTS]
    if unknown:
        parser.error(f"unknown variants {unknown}")
    results: dict[str, list[dict[str, Any]]] = {name: [] for name in names}
    for round_ in range(args.rounds):
        for name in names:
            result = run_variant(name, args.seconds, args.out / f"{name}_{round_}")
            results[name].append(result)
            cpu = ", ".join(f"{n} {v:.0f}" for n, v in result["cpu"].items())
            print(
                f"round {round_ + 1} {name:11s}: CPU % {cpu}, total {result['total']:.0f}; "
                f"model p99 period error {result['period_error_p99_us']:.0f} us, latency "
                f"{result['latency_p99_us']:.0f} us; {result['published']} published, "
                f"{result['unpredicted']} unpredicted, {result['lost']} lost by the recorder; "
                f"exit {result['exit_codes']}; load {os.getloadavg()[0]:.1f}",
                flush=True,
            )
            if result["threads"]:
                busiest = sorted(result["threads"].items(), key=lambda item: -item[1])
                print(
                    "  threads (CPU %): "
                    + ", ".join(f"{comm} {value:.1f}" for comm, value in busiest if value >= 0.5)
                )
    columns = (*NODES, "shared")
    print(f"\nmean over {args.rounds} round(s) of {args.seconds:g} s, CPU % of one core:")
    print(f"{'variant':12s}" + "".join(f"{n:>16s}" for n in columns) + f"{'total':>8s}")
    for name, runs in results.items():
        means = {n: sum(r["cpu"].get(n, 0.0) for r in runs) / len(runs) for n in columns}
        total = sum(r["total"] for r in runs) / len(runs)
        print(f"{name:12s}" + "".join(f"{means[n]:16.0f}" for n in columns) + f"{total:8.0f}")
    print("(one_process: per node its own threads; shared: the middleware's and the main thread)")
    if args.json:
        args.json.write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
