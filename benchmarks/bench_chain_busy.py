"""The node chain on a recording beside 0, 1, 2 busy processes: does it keep real time?

Each run is the chain as a user starts it (``python -m brake_hil.nodes.chain RECORDING --model
RIG --layout L``, from a checkout's own ``.venv``) with N processes spinning
``while 1: pass`` beside it. Per run:

* cycles scored / expected: the fewest steady cycles the comparator scored on a channel
  (``comparator.json``) against those the offline ``brake-hil compare`` scores on the same
  recording and rig file;
* replay wall / length: the source's replay, from its "starting" to its "replay finished" log
  line, against the recording's length;
* the model's latency p99 (input arrival -> prediction published) and stamp age p99 (the
  sample's stamp -> published: how far behind the recording's clock it ran), from its
  statistics file;
* lost: messages the recorder's MCAP misses (``p_i``, the measured and predicted topics)
  against what the source published and the model predicted;
* the chain's exit status;
* CPU of the node processes over the replay (user + system from ``/proc/PID/stat``, polled,
  % of one core), and that total against the middleware's floor for the same traffic:
  ``bench_middleware_floor.py --variant separate`` (bare rclpy nodes that only publish and
  take the chain's messages) run under the same busy processes, in the same run; a
  one-process layout (``one-process``, ``one-paired``) against ``--variant one-process`` (the
  same bare nodes in one process), measured when such a layout is run.

Variants (``--variant NAME=CHECKOUT:LAYOUT[:PRIORITY]``, repeatable; PRIORITY is the chain's
``--realtime-priority``) are interleaved for each busy level (variant a, b, a, b, ... for
``--rounds``) so the shared machine's other load falls on all alike; the load average is
printed with every row. Run from a checkout::

    .venv/bin/python benchmarks/bench_chain_busy.py --busy 0,1,2
        --variant before=../main:processes --variant after=.:processes
        --variant after-paired=.:paired   (one command line)
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator, Sequence
import contextlib
from dataclasses import dataclass, field
import json
import os
from pathlib import Path
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from typing import Any

PROJECT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(PROJECT))

from brake_hil.io.recording_reader import list_topics  # noqa: E402
from brake_hil.topics import (  # noqa: E402
    MASTER_CYLINDER_PRESSURE,
    MEASURED_OUTPUTS,
    PREDICTED_OUTPUTS,
)

RECORDING = PROJECT / "bags" / "one_washer_open"
CHANNELS = ("p_b", "F_k", "x_c")
POLL_S = 0.2
CLK_TCK = os.sysconf("SC_CLK_TCK")
LOG_TIME = re.compile(r"^\[\w+\] \[(\d+\.\d+)\]")
NODE_MODULE = re.compile(r"brake_hil\.nodes\.(\w+)")


@dataclass
class Variant:
    """A checkout's chain in one layout."""

    name: str
    checkout: Path
    layout: str
    realtime_priority: int = 0


@dataclass
class Run:
    """What one chain run gave."""

    variant: str
    busy: int
    load: float
    exit_code: int
    cycles: int | None = None
    replay_s: float | None = None
    length_s: float | None = None
    latency_p99_us: Any = None
    stamp_age_p99_us: Any = None
    lost: int | None = None
    cpu: dict[str, float] = field(default_factory=dict)
    note: str = ""


# --------------------------------------------------------------------------- processes


@contextlib.contextmanager
def busy_processes(count: int) -> Iterator[None]:
    """``count`` processes spinning ``while 1: pass`` until the block ends."""
    spinners = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(count)]
    try:
        yield
    finally:
        for spinner in spinners:
            spinner.kill()
            spinner.wait()


def _stat(pid: int) -> tuple[int, float] | None:
    """(parent pid, CPU seconds) of a process; None when it is gone."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2 :].split()
    return int(fields[1]), (int(fields[11]) + int(fields[12])) / CLK_TCK


def _label(pid: int) -> str:
    """The node(s) a process runs: ``recorder``, or ``container: a+b`` for a container."""
    try:
        argv = Path(f"/proc/{pid}/cmdline").read_bytes().decode().split("\0")
    except OSError:
        return "?"
    modules = [m.group(1) for arg in argv if (m := NODE_MODULE.search(arg))]
    if "container" in modules:
        nodes = [argv[i + 1] for i, arg in enumerate(argv[:-1]) if arg == "--node"]
        return "+".join(nodes) or "container"
    return modules[0] if modules else Path(argv[0]).name


def descendants_cpu(root: int) -> dict[int, float]:
    """CPU seconds of every live process below ``root``."""
    parents: dict[int, int] = {}
    cpu: dict[int, float] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit() and (stat := _stat(int(entry))) is not None:
            parents[int(entry)], cpu[int(entry)] = stat
    found: dict[int, float] = {}
    for pid in cpu:
        parent = parents.get(pid)
        while parent and parent != root:
            parent = parents.get(parent)
        if parent == root:
            found[pid] = cpu[pid]
    return found


def run_chain(variant: Variant, recording: Path, model: Path, out: Path) -> tuple[int, list]:
    """Run the chain; its exit status and the CPU samples (wall time, {pid: cpu s})."""
    env = {**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    command = [
        str(variant.checkout / ".venv" / "bin" / "python"),
        *("-m", "brake_hil.nodes.chain", str(recording), "--model", str(model)),
        *("--out", str(out), "--layout", variant.layout),
        *("--realtime-priority", str(variant.realtime_priority)),
    ]
    samples: list[tuple[float, dict[int, float]]] = []
    labels: dict[int, str] = {}
    with (out.parent / f"{out.name}.log").open("w") as log:
        chain = subprocess.Popen(command, cwd=variant.checkout, env=env, stdout=log, stderr=log)
        try:
            while chain.poll() is None:
                cpu = descendants_cpu(chain.pid)
                for pid in cpu:
                    if pid not in labels:
                        labels[pid] = _label(pid)
                samples.append((time.time(), cpu))
                time.sleep(POLL_S)
        except BaseException:  # interrupted: the chain stops its nodes itself on SIGINT
            chain.send_signal(signal.SIGINT)
            chain.wait(180.0)
            raise
    named = [(t, {labels[p]: v for p, v in cpu.items() if p in labels}) for t, cpu in samples]
    return chain.returncode, named


# --------------------------------------------------------------------------- figures


def replay_window(logs: Path) -> tuple[float, float] | None:
    """Wall times (s since the epoch) of the source's first sample and end of replay.

    From the source's log lines (its own log, or its container's): "...: starting" plus its
    ``start_delay``, and "replay finished".
    """
    start = end = None
    delay = 0.0
    with contextlib.suppress(OSError, ValueError):
        params = (logs / "pressure_source.params.yaml").read_text()
        if (found := re.search(r"start_delay: ([\d.eE+-]+)", params)) is not None:
            delay = float(found.group(1))
    for log in sorted(logs.glob("*.log")):
        with contextlib.suppress(OSError):
            for line in log.read_text().splitlines():
                match = LOG_TIME.match(line)
                if match is None or "[pressure_source]" not in line:
                    continue
                if start is None and line.rstrip().endswith("starting"):
                    start = float(match.group(1)) + delay
                elif "replay finished" in line:
                    end = float(match.group(1))
    return (start, end) if start is not None and end is not None else None


def received_span(out: Path) -> tuple[float, float] | None:
    """Wall times (s) of the first and last ``p_i`` the recorder received (its log times)."""
    from mcap.reader import make_reader

    first = last = None
    for path in sorted(out.glob("*/*.mcap")):
        with path.open("rb") as stream:
            reader = make_reader(stream)
            for _, channel, message in reader.iter_messages():
                if channel.topic != MASTER_CYLINDER_PRESSURE.name:
                    continue
                first = message.log_time if first is None else min(first, message.log_time)
                last = message.log_time if last is None else max(last, message.log_time)
    return (first / 1e9, last / 1e9) if first is not None and last is not None else None


def _cpu_at(samples: list, when: float) -> dict[str, float]:
    """Each process's CPU seconds at the last sample before ``when``."""
    best: dict[str, float] = {}
    for stamp, cpu in samples:
        if stamp > when:
            break
        best = cpu
    return best


def window_cpu(samples: list, start: float, end: float) -> dict[str, float]:
    """CPU % of one core per process label between two wall times."""
    first, last = _cpu_at(samples, start), _cpu_at(samples, end)
    span = max(end - start, 1e-9)
    return {
        label: 100.0 * (value - first.get(label, 0.0)) / span
        for label, value in last.items()
        if label not in ("?",)
    }


def recorder_lost(out: Path, published: int, predicted: int) -> int | None:
    """Messages of the chain's topics missing from the recorder's MCAP; None without one."""
    bags = [p.parent for p in out.glob("*/metadata.yaml")]
    if not bags:
        return None
    counts = {t.name: t.message_count for t in list_topics(bags[0])}
    source = (MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS)
    lost = sum(max(0, published - counts.get(spec.name, 0)) for spec in source)
    return lost + sum(max(0, predicted - counts.get(s.name, 0)) for s in PREDICTED_OUTPUTS)


def _json(path: Path) -> dict[str, Any]:
    try:
        return dict(json.loads(path.read_text()))
    except (OSError, ValueError):
        return {}


def measure(variant: Variant, busy: int, recording: Path, model: Path, out: Path) -> Run:
    """One chain run of ``variant`` beside ``busy`` spinning processes."""
    if out.exists():
        shutil.rmtree(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with busy_processes(busy):
        code, samples = run_chain(variant, recording, model, out)
        load = os.getloadavg()[0]
    run = Run(variant.name, busy, load, code)
    comparator = _json(out / "comparator.json").get("metrics", {})
    scored = [int(comparator.get(ch, {}).get("cycles", 0)) for ch in CHANNELS]
    run.cycles = min(scored) if comparator else None
    log = (out.parent / f"{out.name}.log").read_text()
    if (length := re.search(r"\(([\d.]+) s at rate", log)) is not None:
        run.length_s = float(length.group(1))
    window = replay_window(out / "logs")
    if window is None:  # an older source logs "starting" only after a wait over 1 s
        window = received_span(out)
        run.note = "(replay: p_i as the recorder received it)"
    if window is not None:
        run.replay_s = window[1] - window[0]
        run.cpu = window_cpu(samples, *window)
    model_stats = _json(out / "caliper_model.json")
    run.latency_p99_us = model_stats.get("latency", {}).get("p99_us")
    run.stamp_age_p99_us = model_stats.get("stamp_age", {}).get("p99_us")
    published = int(_json(out / "pressure_source.json").get("published", 0))
    predicted = int(model_stats.get("counters", {}).get("predictions", 0))
    run.lost = recorder_lost(out, published, predicted)
    if not run.cpu:
        run.note = "no replay window: no source log, no p_i recorded"
    return run


ONE_PROCESS_LAYOUTS = ("one-process", "one-paired")
"""Layouts whose CPU is set against the one-process floor (the others: four processes)."""


def middleware_floor(seconds: float, busy: int, variant: str = "separate") -> float | None:
    """The bare-rclpy floor of the chain's traffic (% of one core).

    ``variant`` of ``bench_middleware_floor.py``: ``separate`` (four processes), ``one-process``.
    """
    script = PROJECT / "benchmarks" / "bench_middleware_floor.py"
    command = [sys.executable, str(script), "--seconds", str(seconds), "--variant", variant]
    with busy_processes(busy):
        done = subprocess.run(command, capture_output=True, text=True, check=False)
    match = re.search(r"^total(?: \(one process\))?\s+([\d.]+)", done.stdout, re.MULTILINE)
    if match is None:
        print(f"floor: no figure (exit {done.returncode}): {done.stderr.strip()[-300:]}")
        return None
    return float(match.group(1))


# --------------------------------------------------------------------------- printing


def _us(value: Any) -> str:
    if isinstance(value, int | float):
        return f"{value / 1000:.1f} ms" if value >= 1000 else f"{value:.0f} us"
    return "-" if value is None else str(value)


def row(run: Run, expected: int | None, floor: float | None) -> str:
    """One line of the table."""
    cycles = "-" if run.cycles is None else f"{run.cycles}/{expected if expected else '?'}"
    if run.replay_s is not None and run.length_s:
        replay = f"{run.replay_s:.1f}/{run.length_s:.1f} s"
    else:
        replay = "-"
    total = sum(run.cpu.values())
    ratio = f"{total / floor:.2f}" if floor and run.cpu else "-"
    cpu = ", ".join(f"{name} {value:.0f}" for name, value in sorted(run.cpu.items()))
    lost = "-" if run.lost is None else str(run.lost)
    return (
        f"{run.busy:>4d}  {run.variant:16s}{run.load:6.1f}  {cycles:>8s}  {replay:>13s}  "
        f"{_us(run.latency_p99_us):>10s}  {_us(run.stamp_age_p99_us):>10s}  {lost:>6s}  "
        f"{run.exit_code:>4d}  {total:6.0f}  {ratio:>6s}  {cpu} {run.note}"
    )


HEADER = (
    f"{'busy':>4s}  {'variant':16s}{'load':>6s}  {'cycles':>8s}  {'replay/length':>13s}  "
    f"{'lat. p99':>10s}  {'stamp p99':>10s}  {'lost':>6s}  {'exit':>4s}  {'CPU %':>6s}  "
    f"{'/floor':>6s}  per process (CPU % of one core over the replay)"
)


# --------------------------------------------------------------------------- main


def expected_cycles(checkout: Path, recording: Path, model: Path) -> int | None:
    """The fewest steady cycles the offline ``brake-hil compare`` scores on a channel."""
    with tempfile.TemporaryDirectory() as tmp:
        target = Path(tmp) / "compare.json"
        command = [
            str(checkout / ".venv" / "bin" / "brake-hil"),
            *("compare", str(recording), "--rig", str(model), "--json", str(target)),
        ]
        subprocess.run(command, capture_output=True, check=False, cwd=checkout)
        metrics = _json(target).get("metrics", {})
    if not metrics:
        return None
    return min(int(metrics[ch]["cycles"]) for ch in CHANNELS if ch in metrics)


def parse_variant(text: str) -> Variant:
    """``NAME=CHECKOUT:LAYOUT[:PRIORITY]`` (PRIORITY: the chain's ``--realtime-priority``)."""
    name, _, rest = text.partition("=")
    checkout, layout, *priority = rest.split(":")
    if not name or not checkout or not layout or len(priority) > 1:
        raise argparse.ArgumentTypeError(f"{text!r}: expected NAME=CHECKOUT:LAYOUT[:PRIORITY]")
    try:
        fifo = int(priority[0]) if priority else 0
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: PRIORITY must be an integer") from None
    return Variant(name, Path(checkout).resolve(), layout, fifo)


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    """The command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--recording", type=Path, default=RECORDING)
    parser.add_argument("--model", type=Path, help="default: RECORDING.rig.yaml")
    parser.add_argument("--busy", default="0,1,2", help="busy process counts (default 0,1,2)")
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument(
        "--variant",
        type=parse_variant,
        action="append",
        help="NAME=CHECKOUT:LAYOUT[:PRIORITY], repeatable (default after=.:processes)",
    )
    parser.add_argument("--floor-seconds", type=float, default=10.0, help="0: no floor")
    parser.add_argument("--out", type=Path, default=PROJECT / "out" / "bench_chain_busy")
    parser.add_argument("--json", type=Path, help="every run's figures as JSON")
    args = parser.parse_args(argv)
    args.variant = args.variant or [Variant("after", PROJECT, "processes")]
    args.recording = args.recording.resolve()
    args.model = (args.model or Path(f"{str(args.recording).rstrip('/')}.rig.yaml")).resolve()
    return args


def main(argv: Sequence[str] | None = None) -> int:
    """Run every variant under every busy level, interleaved; print the table."""
    args = parse_args(argv)
    signal.signal(signal.SIGINT, signal.default_int_handler)  # also when started with it ignored
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    expected = expected_cycles(args.variant[-1].checkout, args.recording, args.model)
    print(f"chain on {args.recording} with {args.model}; offline compare: {expected} cycles")
    print(f"{os.cpu_count()} CPUs; CPU % of one core; floor: bare rclpy, same traffic")
    print(HEADER, flush=True)
    runs: list[dict[str, Any]] = []
    for busy in (int(part) for part in args.busy.split(",")):
        floor = middleware_floor(args.floor_seconds, busy) if args.floor_seconds > 0 else None
        print(
            f"{busy:>4d}  {'middleware floor':16s}{os.getloadavg()[0]:6.1f}  "
            f"{'':>60s}{floor if floor is not None else '-'} %",
            flush=True,
        )
        floor_one = None
        if args.floor_seconds > 0 and any(v.layout in ONE_PROCESS_LAYOUTS for v in args.variant):
            floor_one = middleware_floor(args.floor_seconds, busy, "one-process")
            print(
                f"{busy:>4d}  {'floor, 1 process':16s}{os.getloadavg()[0]:6.1f}  "
                f"{'':>60s}{floor_one if floor_one is not None else '-'} %",
                flush=True,
            )
        for round_ in range(args.rounds):
            for variant in args.variant:
                out = args.out / f"{variant.name}_busy{busy}_{round_}"
                run = measure(variant, busy, args.recording, args.model, out)
                mine = floor_one if variant.layout in ONE_PROCESS_LAYOUTS else floor
                print(row(run, expected, mine), flush=True)
                runs.append({**run.__dict__, "floor": mine, "expected": expected})
    if args.json:
        args.json.write_text(json.dumps(runs, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
