"""Soak of the node chain at 1 kHz: timing of the model loop, latency, losses, CPU.

What runs, each its own process on loopback DDS (one ``ROS_DOMAIN_ID`` for the run):

* the chain: ``pressure_source`` looping ``bags/one_washer_lti`` at 1 kHz -> ``caliper_model``
  -> ``comparator``, and the ``recorder`` (when available) recording everything;
* a probe node (this script, ``--role probe``) that subscribes to ``p_i`` and the predicted
  ``p_b`` and pairs them by stamp: end-to-end latency (acquisition stamp -> prediction
  received), input -> prediction latency (both received by the probe), inputs never
  predicted;
* the reference (this script, ``--role reference``): a plain rclpy node with
  ``create_timer(0.001)`` spun by ``rclpy.spin``, measuring each callback's lateness against
  the timer's expected call time (``TimerInfo``), in the same run, under the same load.

Figures: the model loop's period error (median, p99, p99.9, max) and ticks over 1 ms late,
overruns, tick work, input-to-prediction latency inside the model (from its statistics file),
the probe's latencies, input samples without a prediction, messages lost by the recorder
(its MCAP counts against what the source published and the model predicted), CPU per node
over the soak (from ``/proc``). Goals: period error p99 < 100 us, latency p99 < 1 ms, no input
without its prediction, nothing lost.

With ``--layout one-process`` (``--one-process``) the four chain nodes run in one process
(``python -m brake_hil.nodes.container``; the probe and the reference stay processes of their
own): the CPU is then the container's, with its threads by name, and
``--consumers-priority`` applies to the probe only (the recorder and comparator threads share
the container, whose other threads run at normal priority; the loops' SCHED_FIFO is per
thread, as in separate processes). With ``--layout model-apart`` the source, comparator and
recorder share the container and the caliper model runs in its own process.

Run from the repository root (not in CI; takes ``--minutes`` plus ~15 s)::

    .venv/bin/python benchmarks/bench_soak.py --minutes 10 [--realtime-priority 20]
        [--consumers-priority 10] [--out out/bench_soak] [--json FILE] [--keep-bag]
        [--layout processes|one-process|model-apart]

On a machine other work keeps busy, a normal-priority 1 kHz loop cannot keep time (the
reference shows it); ``--realtime-priority`` gives the loops SCHED_FIFO, and
``--consumers-priority`` the recorder, comparator and probe too, so that they keep up.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
import json
import math
import os
from pathlib import Path
import platform
import shutil
import sys
import time
from typing import Any

PROJECT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(PROJECT))

from brake_hil.app.chain import (  # noqa: E402
    CONTAINER_STOP_S,
    LAYOUTS,
    NodeProcess,
    choose_domain_id,
    node_available,
    ros_environment,
    start_layout,
    start_node,
    stop_node,
    thread_cpu_seconds,
    wait_until_quiet,
)
from brake_hil.cli.chain import add_layout_arguments  # noqa: E402
from brake_hil.runtime import Histogram  # noqa: E402
from brake_hil.topics import (  # noqa: E402
    MASTER_CYLINDER_PRESSURE,
    MEASURED_OUTPUTS,
    PREDICTED_BORE_PRESSURE,
    PREDICTED_OUTPUTS,
)

RECORDING = PROJECT / "bags" / "one_washer_lti"
MODEL = PROJECT / "config" / "rig_default.yaml"
IN_FLIGHT_NS = 200_000_000  # inputs this close to the end may still be on their way


# --------------------------------------------------------------------------- roles


def run_probe(out: Path) -> None:
    """Pair p_i with predicted p_b by stamp; write latencies and counts at SIGINT."""
    from brake_hil.nodes import common

    common.init_ros(None)
    from rclpy.node import Node

    node = Node("soak_probe")
    pending_inputs: dict[int, int] = {}
    pending_predictions: dict[int, int] = {}
    end_to_end, chain = Histogram(100_000), Histogram(100_000)
    counts = {"inputs": 0, "predictions": 0}
    read_input = common.raw_reader(MASTER_CYLINDER_PRESSURE)
    read_prediction = common.raw_reader(PREDICTED_BORE_PRESSURE)

    def on_input(data: bytes) -> None:
        received = time.time_ns()
        stamp, _ = read_input(data)
        counts["inputs"] += 1
        predicted = pending_predictions.pop(stamp, None)
        if predicted is None:
            pending_inputs[stamp] = received
        else:
            chain.add(predicted - received)

    def on_prediction(data: bytes) -> None:
        received = time.time_ns()
        stamp, _ = read_prediction(data)
        counts["predictions"] += 1
        end_to_end.add(received - stamp)
        arrived = pending_inputs.pop(stamp, None)
        if arrived is None:
            pending_predictions[stamp] = received
        else:
            chain.add(received - arrived)

    qos = common.SAMPLE_QOS
    node.create_subscription(
        common.message_class(MASTER_CYLINDER_PRESSURE),
        MASTER_CYLINDER_PRESSURE.name,
        on_input,
        qos,
        raw=True,
    )
    node.create_subscription(
        common.message_class(PREDICTED_BORE_PRESSURE),
        PREDICTED_BORE_PRESSURE.name,
        on_prediction,
        qos,
        raw=True,
    )
    common.spin_until_signal(node)
    newest = max(pending_inputs, default=0)
    unpredicted = [s for s in pending_inputs if s < newest - IN_FLIGHT_NS]
    result = {
        **counts,
        "inputs_without_prediction": len(unpredicted),
        "predictions_without_input": len(pending_predictions),
        "end_to_end": end_to_end.summary().as_dict(),
        "input_to_prediction": chain.summary().as_dict(),
    }
    out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    node.destroy_node()
    import rclpy

    rclpy.shutdown()


def run_reference(out: Path) -> None:
    """A plain ``create_timer(0.001)`` under ``rclpy.spin``: lateness of each callback."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.node import Node
    from rclpy.timer import TimerInfo

    rclpy.init()
    node = Node("reference_timer")
    lateness = Histogram(100_000)
    clock = node.get_clock()

    def on_timer(info: TimerInfo) -> None:
        lateness.add(clock.now().nanoseconds - info.expected_call_time.nanoseconds)

    # rclpy passes TimerInfo to a parameter annotated with the class itself, which
    # ``from __future__ import annotations`` turns into a string
    on_timer.__annotations__["info"] = TimerInfo

    node.create_timer(0.001, on_timer)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    result = {
        "period_error": lateness.summary().as_dict(),
        "late_ticks_over_1ms": lateness.count_at_least(1_000_000),
    }
    out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    node.destroy_node()
    rclpy.try_shutdown()


# --------------------------------------------------------------------------- the soak


def _start_role(
    role: str, out: Path, env: dict[str, str], logs: Path, fifo_priority: int = 0
) -> NodeProcess:
    import subprocess

    from brake_hil.runtime import set_realtime_priority

    logs.mkdir(parents=True, exist_ok=True)
    log = logs / f"{role}.log"
    with log.open("wb") as stream:
        process = subprocess.Popen(
            [sys.executable, str(Path(__file__).resolve()), "--role", role, "--out", str(out)],
            env=env,
            stdout=stream,
            stderr=subprocess.STDOUT,
            start_new_session=True,
            preexec_fn=(lambda: set_realtime_priority(fifo_priority)) if fifo_priority else None,
        )
    return NodeProcess(role, process, log)


def _read(path: Path) -> dict[str, Any]:
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return document if isinstance(document, dict) else {}


def _bag_counts(bag: Path) -> dict[str, int]:
    from brake_hil.io.recording_reader import list_topics

    try:
        return {topic.name: topic.message_count for topic in list_topics(bag)}
    except Exception as err:  # noqa: BLE001 - reported, the rest of the figures stand
        print(f"cannot read the recording {bag}: {err}", file=sys.stderr)
        return {}


def soak(
    minutes: float,
    out: Path,
    realtime_priority: int,
    keep_bag: bool,
    recorder: bool,
    consumers_priority: int = 0,
    layout: str = "processes",
) -> dict[str, Any]:
    """Run the chain for ``minutes`` and collect the figures.

    ``realtime_priority``: SCHED_FIFO of the source's and the model's loops (their other
    threads one below); ``consumers_priority``: SCHED_FIFO of the whole recorder, comparator
    and probe processes (0: normal scheduling). The reference timer always runs normally.
    ``layout``: which chain nodes share a process (:data:`brake_hil.app.chain.LAYOUTS`).
    """
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    logs = out / "logs"
    domain = choose_domain_id()
    env = ros_environment(domain)
    has_recorder = recorder and node_available("recorder")
    subscribers = 2 if has_recorder else 1
    nodes: list[NodeProcess] = []
    source: NodeProcess | None = None
    elapsed = 1.0
    cpu_start: dict[str, float] = {}
    cpu_end: dict[str, float] = {}
    threads_start: dict[str, float] = {}
    threads_end: dict[str, float] = {}
    containers: list[NodeProcess] = []
    print(
        f"soak: {minutes:g} min, ROS_DOMAIN_ID {domain}, SCHED_FIFO loops "
        f"{realtime_priority or 'off'}, consumers {consumers_priority or 'off'}"
        + ("" if layout == "processes" else f", layout {layout}")
    )
    waits = [f"{MASTER_CYLINDER_PRESSURE.name}:{subscribers + 1}"]
    waits += [f"{spec.name}:{subscribers}" for spec in MEASURED_OUTPUTS]
    waits += [f"{spec.name}:{subscribers}" for spec in PREDICTED_OUTPUTS]
    plan: list[tuple[str, dict[str, Any]]] = []  # start order: readers first
    if has_recorder:
        plan.append(("recorder", {"output_dir": str(out), "bag_name": "soak"}))
    plan.append(("comparator", {"summary_file": str(out / "comparator.json")}))
    plan.append(
        (
            "caliper_model",
            {
                "model_file": str(MODEL),
                "mean_pressure": 1.55e6,
                "statistics_file": str(out / "caliper_model.json"),
                "realtime_priority": realtime_priority,
            },
        )
    )
    plan.append(
        (
            "pressure_source",
            {
                "recording": str(RECORDING),
                "loop": True,
                "wait_for_topics": waits,
                "wait_timeout": 30.0,
                "start_delay": 1.0,
                "realtime_priority": realtime_priority,
                "statistics_file": str(out / "pressure_source.json"),
            },
        )
    )
    try:
        nodes.append(_start_role("reference", out / "reference.json", env, logs))
        if LAYOUTS[layout]:  # some nodes share a process
            nodes.append(_start_role("probe", out / "probe.json", env, logs, consumers_priority))
            nodes.extend(start_layout(plan, env, logs, layout))
            containers = [n for n in nodes if n.is_container]
            source = next(n for n in nodes if n.runs("pressure_source"))  # stopped first
        else:
            for name, parameters in plan[:-1]:
                priority = consumers_priority if name in ("recorder", "comparator") else 0
                nodes.append(start_node(name, parameters, env, logs, priority))
            nodes.append(_start_role("probe", out / "probe.json", env, logs, consumers_priority))
            source = start_node(*plan[-1], env, logs)
            nodes.append(source)
        time.sleep(8.0)  # start-up: imports, discovery, the source's wait
        cpu_start = {n.name: n.cpu_seconds() or 0.0 for n in nodes}
        threads_start = thread_cpu_seconds(containers)
        started = time.monotonic()
        time.sleep(minutes * 60.0)
        elapsed = time.monotonic() - started
        cpu_end = {n.name: n.cpu_seconds() or 0.0 for n in nodes}
        threads_end = thread_cpu_seconds(containers)
    finally:
        exit_codes = {}
        if source is not None:
            exit_codes[source.name] = stop_node(
                source, CONTAINER_STOP_S if source.is_container else 10.0
            )
            time.sleep(1.0)  # in flight: the last predictions, the recorder's queues
        for node in reversed(nodes):
            if node.name not in exit_codes:
                if node.name == "recorder" and (out / "soak").is_dir():
                    wait_until_quiet(out / "soak")  # as the launcher: it has caught up
                timeout_s = CONTAINER_STOP_S if node.is_container else 10.0
                exit_codes[node.name] = stop_node(node, timeout_s)
    cpu = {
        name: 100.0 * (cpu_end[name] - cpu_start.get(name, 0.0)) / elapsed
        for name in cpu_end
        if name in cpu_start
    }
    threads = {
        comm: 100.0 * (value - threads_start.get(comm, 0.0)) / elapsed
        for comm, value in threads_end.items()
    }
    result: dict[str, Any] = {
        "minutes": minutes,
        "realtime_priority": realtime_priority,
        "consumers_priority": consumers_priority,
        "machine": {
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "load_average": os.getloadavg(),
        },
        "caliper_model": _read(out / "caliper_model.json"),
        "pressure_source": _read(out / "pressure_source.json"),
        "probe": _read(out / "probe.json"),
        "reference": _read(out / "reference.json"),
        "comparator": _read(out / "comparator.json"),
        "cpu_percent": cpu,
        "container_threads_cpu_percent": threads,
        "layout": layout,
        "exit_codes": exit_codes,
    }
    if has_recorder and (out / "soak" / "metadata.yaml").is_file():
        counts = _bag_counts(out / "soak")
        published = result["pressure_source"].get("published", 0)
        predicted = result["caliper_model"].get("counters", {}).get("predictions", 0)
        expected = {MASTER_CYLINDER_PRESSURE.name: published}
        expected |= {spec.name: published for spec in MEASURED_OUTPUTS}
        expected |= {spec.name: predicted for spec in PREDICTED_OUTPUTS}
        result["recorder"] = {
            "counts": counts,
            "lost": {name: n - counts.get(name, 0) for name, n in expected.items()},
        }
        if not keep_bag:
            shutil.rmtree(out / "soak")
    return result


def _us(summary: dict[str, float], key: str) -> str:
    value = summary.get(key)
    if value is None:
        return "-"
    ceiling = summary.get("ceiling_us", math.inf)
    return f">{ceiling / 1000:.0f}ms" if value >= ceiling else f"{value:.0f}"


def report(result: dict[str, Any]) -> None:
    """Print the figures."""
    model = result["caliper_model"]
    reference = result["reference"]
    rows = [
        ("caliper_model loop", model.get("period_error", {}), model.get("late_ticks_over_1ms")),
        (
            "reference create_timer",
            reference.get("period_error", {}),
            reference.get("late_ticks_over_1ms"),
        ),
    ]
    print(
        f"\nperiod error (us){'':12s}{'median':>8s}{'p99':>8s}{'p99.9':>8s}{'max':>8s}"
        f"{'>1 ms':>8s}{'ticks':>9s}"
    )
    for name, summary, late in rows:
        print(
            f"{name:29s}{_us(summary, 'median_us'):>8s}{_us(summary, 'p99_us'):>8s}"
            f"{_us(summary, 'p999_us'):>8s}{_us(summary, 'max_us'):>8s}{late!s:>8s}"
            f"{int(summary.get('samples', 0)):9d}"
        )
    counters = model.get("counters", {})
    print(
        f"model: {counters.get('samples')} samples in, {counters.get('predictions')} "
        f"predictions out, overruns {counters.get('overruns')}, skipped slots "
        f"{counters.get('ticks_skipped')}, caught-up ticks {counters.get('caught_up_ticks')} "
        f"(max {counters.get('max_per_tick')} samples in a tick), phase shifts "
        f"{counters.get('phase_shifts')}"
    )
    print(f"\nlatency (us){'':17s}{'median':>8s}{'p99':>8s}{'p99.9':>8s}{'max':>8s}")
    probe = result["probe"]
    for name, summary in (
        ("model: arrival -> published", model.get("latency", {})),
        ("model: arrival -> its tick", model.get("input_wait", {})),
        ("model: tick work", model.get("tick_work", {})),
        ("model: one step", model.get("step_time", {})),
        ("probe: input -> prediction", probe.get("input_to_prediction", {})),
        ("probe: stamp -> prediction", probe.get("end_to_end", {})),
    ):
        print(
            f"{name:29s}{_us(summary, 'median_us'):>8s}{_us(summary, 'p99_us'):>8s}"
            f"{_us(summary, 'p999_us'):>8s}{_us(summary, 'max_us'):>8s}"
        )
    print(
        f"\nprobe: {probe.get('inputs')} inputs, {probe.get('predictions')} predictions, "
        f"{probe.get('inputs_without_prediction')} inputs without a prediction"
    )
    source = result["pressure_source"]
    print(
        f"source: {source.get('published')} samples published in {source.get('passes')} "
        f"passes; its period error {source.get('period_error')}"
    )
    if "recorder" in result:
        print(f"recorder: lost {result['recorder']['lost']}")
    else:
        print("recorder: not run")
    print("CPU %: " + ", ".join(f"{k} {v:.0f}" for k, v in result["cpu_percent"].items()))
    chain = sum(v for k, v in result["cpu_percent"].items() if k not in ("probe", "reference"))
    print(f"CPU % of the chain's four nodes together: {chain:.0f}")
    threads = sorted(result.get("container_threads_cpu_percent", {}).items(), key=lambda i: -i[1])
    if threads:
        print(
            "container threads, CPU %: "
            + ", ".join(f"{comm} {value:.1f}" for comm, value in threads if value >= 0.5)
        )
    print(f"exit codes: {result['exit_codes']}; load average {result['machine']['load_average']}")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the soak (or this script's probe or reference role) and print its figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument(
        "--realtime-priority",
        type=int,
        default=0,
        help="SCHED_FIFO priority of the source's and model's loops (0: off)",
    )
    parser.add_argument(
        "--consumers-priority",
        type=int,
        default=0,
        help="SCHED_FIFO priority of the recorder, comparator and probe processes (0: off)",
    )
    parser.add_argument("--out", type=Path, default=PROJECT / "out" / "bench_soak")
    parser.add_argument("--json", type=Path, help="write the figures here too")
    parser.add_argument("--keep-bag", action="store_true", help="keep the recorder's MCAP")
    parser.add_argument("--no-recorder", action="store_true")
    add_layout_arguments(parser, default="processes")
    parser.add_argument("--role", choices=("probe", "reference"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.role == "probe":
        run_probe(args.out)
        return 0
    if args.role == "reference":
        run_reference(args.out)
        return 0
    result = soak(
        args.minutes,
        args.out,
        args.realtime_priority,
        args.keep_bag,
        not args.no_recorder,
        args.consumers_priority,
        args.layout,
    )
    report(result)
    if args.json:
        args.json.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
