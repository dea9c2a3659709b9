"""Messages a ``kill -9`` of the recorder loses, against chunk size and chunk age bound.

For each setting (``chunk_bytes``, ``flush_interval_s``) and each of ``--kills`` runs: start
the recorder (its own process, loopback DDS, a fresh domain), publish the six sample topics
of docs/interface.md and ``/diagnostics`` at 1 kHz from this process (7 000 messages/s, CDR), and
``SIGKILL`` the recorder at a random moment 1.5-3.5 s into the stream. Lost = published
before the kill - recovered from the files (every whole chunk, read as the project's reader
reads an unfinished recording), per topic; reported as the maximum over the topics of each
run, then median / p95 / max over the runs, in messages and in ms of a 1 kHz topic.

The loss has two parts, measured apart on the recorder's own clock (a message's log time is
when the recorder received it; same host clock as this script's):

* *open chunk*: kill time - the newest log time on disk: received but not yet committed, the
  part ``flush_interval_s`` and ``chunk_bytes`` bound;
* *backlog*: that newest message's log time - its publish time: how far behind the
  publisher the recorder was (DDS had not yet delivered it; 0 on an idle machine, grows when
  other work starves the recorder of CPU).

Also the recorder's CPU while recording (``/proc``, user + system over the publishing time).

Run from the repository root (not in CI; about 5 s a kill)::

    .venv/bin/python benchmarks/bench_recorder_kill.py [--kills 20] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time
from typing import Any

PROJECT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(PROJECT))

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus  # noqa: E402
import numpy as np  # noqa: E402
import rclpy  # noqa: E402
from rclpy.context import Context  # noqa: E402
from rclpy.node import Node  # noqa: E402

from brake_hil.app.chain import ros_environment  # noqa: E402
from brake_hil.io.mcap_salvage import salvage_file  # noqa: E402
from brake_hil.nodes import common  # noqa: E402
from brake_hil.runtime import loopback_environment  # noqa: E402
from brake_hil.topics import AIR_PRESSURE, MASTER_CYLINDER_PRESSURE, MEASURED_OUTPUTS  # noqa: E402

TOPICS = (MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS, AIR_PRESSURE)
SETTINGS = (  # (chunk_bytes, flush_interval_s)
    (1 << 20, 1.0),  # the defaults before: 1 MiB, commit at least every second
    (64 << 10, 1.0),  # a small chunk, the old time bound
    (1 << 20, 0.1),  # the default now
    (1 << 20, 0.02),
)
T0 = 1_700_000_000_000_000_000


class Source:
    """A real rclpy node publishing sample k of every topic (and /diagnostics) at 1 kHz."""

    def __init__(self, domain: int) -> None:
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = Node("kill_bench_source", context=self.context)
        self.outputs = [
            (
                self.node.create_publisher(
                    common.message_class(spec), spec.name, common.SAMPLE_QOS
                ),
                common.RawMessageBuilder(spec, "rig"),
            )
            for spec in TOPICS
        ]
        self.diagnostics = self.node.create_publisher(
            DiagnosticArray, "/diagnostics", common.DIAGNOSTICS_QOS
        )
        self.published = 0
        self.publish_ns: list[int] = []  # wall clock when sample k was published
        self.stop = threading.Event()

    def wait_for_recorder(self, timeout_s: float = 30.0) -> None:
        """Wait until the recorder subscribed to every topic."""
        publishers = [p for p, _ in self.outputs] + [self.diagnostics]
        deadline = time.monotonic() + timeout_s
        while not all(p.get_subscription_count() for p in publishers):
            if time.monotonic() > deadline:
                raise RuntimeError("the recorder did not subscribe in time")
            time.sleep(0.05)

    def run(self) -> None:
        """Publish at 1 kHz on absolute deadlines until :attr:`stop` is set."""
        array = DiagnosticArray()
        array.status = [DiagnosticStatus(name="bench", message="")]
        start = time.monotonic_ns() + 1_000_000
        k = 0
        while not self.stop.is_set():
            delay = start + k * 1_000_000 - time.monotonic_ns()
            if delay > 0:
                time.sleep(delay / 1e9)
            stamp = T0 + k * 1_000_000
            self.publish_ns.append(time.time_ns())
            for publisher, build in self.outputs:
                publisher.publish(build(stamp, float(k)))
            array.status[0].message = str(k)
            self.diagnostics.publish(array)
            k += 1
            self.published = k

    def close(self) -> None:
        """Stop and shut this node's context down."""
        self.stop.set()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process (s)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def one_kill(
    out: Path, domain: int, chunk_bytes: int, flush_s: float, rng: random.Random
) -> dict[str, Any]:
    """One recorder run killed at a random moment; what was published and recovered."""
    command = [sys.executable, "-m", "brake_hil.nodes.recorder", "--ros-args"]
    parameters = {
        "output_dir": str(out),
        "bag_name": "bag",
        "chunk_bytes": chunk_bytes,
        "flush_interval_s": flush_s,
    }
    for name, value in parameters.items():
        command += ["-p", f"{name}:={value}"]
    source = Source(domain)
    process = subprocess.Popen(
        command,
        env=ros_environment(domain),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        source.wait_for_recorder()
        time.sleep(0.3)  # the recorder's subscriptions matched on its side too
        thread = threading.Thread(target=source.run, daemon=True)
        cpu_before, began = cpu_seconds(process.pid), time.monotonic()
        thread.start()
        time.sleep(rng.uniform(1.5, 3.5))
        cpu = cpu_seconds(process.pid) - cpu_before
        killed_ns = time.time_ns()
        process.send_signal(signal.SIGKILL)
        published = source.published
        wall = time.monotonic() - began
        process.wait(10)
        source.stop.set()
        thread.join(5)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait(10)
        source.close()
    recovered: dict[str, int] = {}
    newest: tuple[int, int] = (0, 0)  # (log time, k) of the newest sample on disk
    readers = {spec.name: common.raw_reader(spec) for spec in TOPICS}
    for file in sorted((out / "bag").glob("*.mcap")):
        salvaged = salvage_file(file)
        for message in salvaged.messages:
            topic = salvaged.channels[message.channel_id].topic
            recovered[topic] = recovered.get(topic, 0) + 1
            if topic in readers and message.log_time_ns > newest[0]:
                stamp, _ = readers[topic](message.data)
                newest = (message.log_time_ns, (stamp - T0) // 1_000_000)
    names = [s.name for s in TOPICS] + ["/diagnostics"]
    lost = {name: published - recovered.get(name, 0) for name in names}
    log_ns, k = newest
    return {
        "published": published,
        "lost_max": max(lost.values()),
        "lost_min": min(lost.values()),
        "open_chunk_ms": (killed_ns - log_ns) / 1e6 if log_ns else float("nan"),
        "backlog_ms": (log_ns - source.publish_ns[k]) / 1e6 if log_ns else float("nan"),
        "cpu_percent": 100.0 * cpu / wall,
    }


def main() -> None:
    """Run every setting ``--kills`` times and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--kills", type=int, default=20)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", type=Path)
    parser.add_argument(
        "--setting",
        action="append",
        metavar="CHUNK_BYTES:FLUSH_S",
        help="run only these settings (repeatable); default: the four of the table",
    )
    args = parser.parse_args()
    loopback_environment(os.environ)  # this process's source on loopback, as the recorder's
    settings = SETTINGS
    if args.setting:
        pairs = [text.split(":") for text in args.setting]
        settings = tuple((int(chunk), float(flush)) for chunk, flush in pairs)
    rng = random.Random(args.seed)
    results: list[dict[str, Any]] = []
    print(f"{args.kills} kills per setting, 7 topics at 1 kHz; lost = max over the topics")
    print(
        f"{'chunk_bytes':>11} {'flush_s':>7} | {'lost median':>11} {'p95':>5} {'max':>5} |"
        f" {'open chunk ms median':>20} {'p95':>5} {'max':>5} |"
        f" {'backlog ms median':>17} {'p95':>5} {'max':>5} | {'CPU %':>5}"
    )
    for chunk_bytes, flush_s in settings:
        runs = []
        for kill in range(args.kills):
            with tempfile.TemporaryDirectory(prefix="kill_bench_") as tmp:
                domain = 101 + (os.getpid() + 17 * kill + int(flush_s * 1000)) % 100
                runs.append(one_kill(Path(tmp), domain, chunk_bytes, flush_s, rng))
        row: dict[str, Any] = {"chunk_bytes": chunk_bytes, "flush_interval_s": flush_s}
        cells = []
        for key in ("lost_max", "open_chunk_ms", "backlog_ms"):
            values = np.array([r[key] for r in runs], dtype=float)
            figures = np.median(values), np.percentile(values, 95), values.max()
            row[key] = dict(zip(("median", "p95", "max"), map(float, figures), strict=True))
            cells.append(figures)
        row["cpu_percent_median"] = float(np.median([r["cpu_percent"] for r in runs]))
        row["runs"] = runs
        results.append(row)
        (lost, opened, backlog) = cells
        print(
            f"{chunk_bytes:>11} {flush_s:>7.2f} | {lost[0]:>11.0f} {lost[1]:>5.0f} "
            f"{lost[2]:>5.0f} | {opened[0]:>20.0f} {opened[1]:>5.0f} {opened[2]:>5.0f} | "
            f"{backlog[0]:>17.0f} {backlog[1]:>5.0f} {backlog[2]:>5.0f} | "
            f"{row['cpu_percent_median']:>5.1f}",
            flush=True,
        )
    if args.json:
        args.json.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
