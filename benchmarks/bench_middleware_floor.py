"""CPU floor of the chain's message traffic at 1 kHz: bare rclpy nodes that do nothing else.

The claim checked: the chain's CPU (107-122 % of one core for the four nodes, goal 60 %) is
the cost of rclpy -> rmw -> Fast DDS per publish and per delivery, so nodes that only publish
and receive the chain's messages already exceed the goal. Four bare nodes reproduce the
chain's traffic with the contract's message types (``brake_hil/topics.py``), the project's
``SAMPLE_QOS`` and executor (``make_executor``: rclpy's EventsExecutor), and messages
serialised as the project's nodes publish and take them (``RawMessageBuilder``,
``raw=True``):

* ``source``: ``p_i``, ``p_b``, ``F_k``, ``x_c``, one message per topic per millisecond, stamped,
  from the project's :class:`~brake_hil.runtime.DeadlineLoop` sleeping to each deadline (no
  spin; a late tick publishes the slots it passed over, so the traffic stays 1000/s);
* ``model``: takes ``p_i`` and publishes the three predictions per sample, with its stamp;
* ``comparator``: takes the three measured and three predicted topics (callback only counts);
* ``recorder``: takes all seven (callback only counts).

Variants: ``separate`` (each node its own process, as the chain runs) and ``one-process``
(the four nodes in one process and one executor: one DDS participant, Fast DDS's
intraprocess delivery). Every process runs local-only with the project's loopback profile
(``SYSTEM_DEFAULT`` with it: ``brake_hil.app.chain.ros_environment``). After a warm-up,
each process's CPU (user + system, ``/proc/PID/stat``) is read over ``--seconds``, and every
node counts what it published and received per topic; at the end the source stops and the
subscribers are given time to receive the rest, so messages lost are counted, not guessed.

Exit status: 0; 1 when a node did not start, received nothing in the window, or lost
messages (the table is printed first); 2 when the environment is not local-only on loopback.

Run from the checkout (the real measurement, on a quiet machine)::

    .venv/bin/python benchmarks/bench_middleware_floor.py --seconds 20 --variant both
"""

from __future__ import annotations

import argparse
from collections import deque
from collections.abc import Callable, Iterator, Mapping, Sequence
import contextlib
from dataclasses import dataclass, field
import json
import os
from pathlib import Path
import queue
import signal
import subprocess
import sys
import threading
import time
from typing import Any

PROJECT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(PROJECT))

from brake_hil.app.chain import ros_environment  # noqa: E402
from brake_hil.runtime import security_problem  # noqa: E402
from brake_hil.topics import (  # noqa: E402
    MASTER_CYLINDER_PRESSURE,
    MEASURED_OUTPUTS,
    PREDICTED_OUTPUTS,
    TopicSpec,
)

NAME = "bench_middleware_floor"
GOAL_PERCENT = 60.0
"""The project's goal: the four chain nodes together under 60 % of one core at 1 kHz."""
ROLES = ("comparator", "recorder", "model", "source")
"""The bare nodes, in the order they are built (readers before their writers)."""
SOURCE_TOPICS = (MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS)
COMPARATOR_TOPICS = (*MEASURED_OUTPUTS, *PREDICTED_OUTPUTS)
RECORDER_TOPICS = (*SOURCE_TOPICS, *PREDICTED_OUTPUTS)
READERS_PER_TOPIC = 2
"""Every topic has two readers: p_i the model and recorder, the others comparator and recorder."""
MARK = "FLOOR "
"""Prefix of the lines a node process writes to the benchmark (JSON after it)."""
START_DELAY_S = 0.5
"""Pause between the source's writers matching their readers and its first sample (s)."""
SETTLE_QUIET_S = 3.0
"""At the end, the subscribers are given up to this long without progress to catch up (s)."""
SETTLE_MAX_S = 30.0


class FloorError(Exception):
    """A node that did not start, failed, or received nothing: one line, exit 1."""


# --------------------------------------------------------------------------- node processes


def _wait_for_readers(
    writers: Sequence[tuple[str, Any]], readers: int, timeout_s: float
) -> str | None:
    """Wait until every writer has matched ``readers`` readers; why not, or None."""
    deadline = time.monotonic() + timeout_s
    while True:
        missing = [
            (name, writer.get_subscription_count())
            for name, writer in writers
            if writer.get_subscription_count() < readers
        ]
        if not missing:
            return None
        if time.monotonic() > deadline:
            found = ", ".join(f"{name} {count}" for name, count in missing)
            return f"its writers found fewer than {readers} readers in {timeout_s:g} s ({found})"
        time.sleep(0.02)


class BareSource:
    """``p_i``, ``p_b``, ``F_k``, ``x_c`` at 1 kHz on absolute deadlines, nothing else."""

    name = "source"

    def __init__(self, node: Any) -> None:
        from brake_hil.nodes import common
        from brake_hil.runtime import DeadlineLoop

        self.writers = [
            (
                spec.name,
                node.create_publisher(common.message_class(spec), spec.name, common.SAMPLE_QOS),
                common.RawMessageBuilder(spec, "floor"),
            )
            for spec in SOURCE_TOPICS
        ]
        self.published = 0  # per topic: every tick publishes on all four
        self._epoch_ns = 0
        self._loop = DeadlineLoop(self._tick, spin_ns=0, name="source-loop")

    def prepare(self, timeout_s: float) -> str | None:
        """Wait for the readers of every topic (so none misses the first samples)."""
        return _wait_for_readers([w[:2] for w in self.writers], READERS_PER_TOPIC, timeout_s)

    def start(self) -> None:
        """Start publishing."""
        self._epoch_ns = time.time_ns() - time.monotonic_ns()
        self._loop.start()

    def stop(self) -> None:
        """Stop publishing (idempotent)."""
        self._loop.stop()

    def _tick(self, tick: Any) -> None:
        period = self._loop.period_ns
        for slot in range(tick.skipped + 1):  # slots passed over are published late
            stamp = self._epoch_ns + tick.deadline_ns + slot * period
            value = 1.0e6 + 1.0e3 * ((tick.slot + slot) % 200)
            for _, writer, build in self.writers:
                writer.publish(build(stamp, value))
            self.published += 1

    def counts(self) -> dict[str, Any]:
        """What it published so far, per topic, and its late ticks."""
        counters = self._loop.statistics.counters
        error = self._loop.error
        return {
            "published": {name: self.published for name, _, _ in self.writers},
            "received": {},
            "late_ticks": counters.late_ticks,
            "slots_passed_over": counters.ticks_skipped,
            "error": None if error is None else f"{type(error).__name__}: {error}",
        }


class BareModel:
    """Takes ``p_i``; per sample publishes the three predictions stamped with its stamp."""

    name = "model"

    def __init__(self, node: Any) -> None:
        from brake_hil.nodes import common

        self._node = node
        self._common = common
        self.writers = [
            (
                spec.name,
                node.create_publisher(common.message_class(spec), spec.name, common.SAMPLE_QOS),
                common.RawMessageBuilder(spec, "floor"),
            )
            for spec in PREDICTED_OUTPUTS
        ]
        self._read = common.raw_reader(MASTER_CYLINDER_PRESSURE)
        self.received = 0
        self.published = 0
        self._subscription: Any = None

    def prepare(self, timeout_s: float) -> str | None:
        """Subscribe to ``p_i`` once the predictions have their readers (as the model does)."""
        problem = _wait_for_readers([w[:2] for w in self.writers], READERS_PER_TOPIC, timeout_s)
        if problem is None:
            spec = MASTER_CYLINDER_PRESSURE
            self._subscription = self._node.create_subscription(
                self._common.message_class(spec),
                spec.name,
                self._on_input,
                self._common.SAMPLE_QOS,
                raw=True,
            )
        return problem

    def _on_input(self, data: bytes) -> None:
        self.received += 1
        stamp, value = self._read(data)
        for _, writer, build in self.writers:
            writer.publish(build(stamp, value))
        self.published += 1

    def counts(self) -> dict[str, Any]:
        """What it received and published so far, per topic."""
        return {
            "published": {name: self.published for name, _, _ in self.writers},
            "received": {MASTER_CYLINDER_PRESSURE.name: self.received},
        }


class BareSink:
    """Takes its topics serialised; the callback only counts."""

    def __init__(self, node: Any, name: str, specs: Sequence[TopicSpec]) -> None:
        from brake_hil.nodes import common

        self.name = name
        self.received = {spec.name: 0 for spec in specs}
        self._subscriptions = [
            node.create_subscription(
                common.message_class(spec),
                spec.name,
                self._counter(spec.name),
                common.SAMPLE_QOS,
                raw=True,
            )
            for spec in specs
        ]

    def _counter(self, topic: str) -> Callable[[bytes], None]:
        received = self.received

        def on_message(data: bytes) -> None:
            received[topic] += 1

        return on_message

    def prepare(self, timeout_s: float) -> str | None:
        """Nothing to wait for."""
        del timeout_s
        return None

    def counts(self) -> dict[str, Any]:
        """What it received so far, per topic."""
        return {"published": {}, "received": dict(self.received)}


def _emit(message: Mapping[str, Any]) -> None:
    print(MARK + json.dumps(message), flush=True)


def _spin(executor: Any, stop: threading.Event, failures: list[str]) -> None:
    # spin_once in a loop, as brake_hil.nodes.common does: the EventsExecutor's shutdown()
    # from another thread does not return while spin() runs.
    try:
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)
    except Exception as err:  # noqa: BLE001 - reported to the benchmark, which fails the run
        failures.append(f"executor stopped: {type(err).__name__}: {err}")


def serve(roles: Sequence[str], start_timeout_s: float) -> int:
    """A node process: the bare nodes of ``roles`` in one executor, driven over stdin.

    Commands, one a line: ``snapshot`` (answer the counts), ``stop`` (the source stops
    publishing; answer the counts), ``exit`` or end of input (quit).
    """
    import rclpy

    from brake_hil.nodes import common

    common.init_ros([])  # keeps the loopback environment the benchmark gave it
    nodes: list[Any] = []
    bare: list[Any] = []
    stop = threading.Event()
    failures: list[str] = []
    executor: Any = None
    thread: threading.Thread | None = None
    try:
        for role in ROLES:
            if role not in roles:
                continue
            node = rclpy.create_node(f"floor_{role}")
            nodes.append(node)
            if role == "source":
                bare.append(BareSource(node))
            elif role == "model":
                bare.append(BareModel(node))
            else:
                topics = COMPARATOR_TOPICS if role == "comparator" else RECORDER_TOPICS
                bare.append(BareSink(node, role, topics))
        for part in bare:
            problem = part.prepare(start_timeout_s)
            if problem is not None:
                print(f"{NAME}: {part.name}: error: {problem}", file=sys.stderr, flush=True)
                return 3
        executor = common.make_executor()
        for node in nodes:
            executor.add_node(node)
        thread = threading.Thread(
            target=_spin, args=(executor, stop, failures), name="executor", daemon=True
        )
        thread.start()
        sources = [part for part in bare if isinstance(part, BareSource)]
        if sources:
            time.sleep(START_DELAY_S)
            for source in sources:
                source.start()
        _emit({"kind": "ready", "executor": type(executor).__name__})
        while line := sys.stdin.readline():
            command = line.strip()
            if command == "exit":
                break
            if command == "stop":
                for source in sources:
                    source.stop()
            if command in ("snapshot", "stop"):
                counts = {part.name: part.counts() for part in bare}
                error = "; ".join(failures) or None
                _emit({"kind": command, "t": time.monotonic(), "nodes": counts, "error": error})
        return 0
    except KeyboardInterrupt:
        return 130
    finally:
        for part in bare:
            if isinstance(part, BareSource):
                part.stop()
        stop.set()
        if thread is not None:
            thread.join(2.0)
        if executor is not None and (thread is None or not thread.is_alive()):
            executor.shutdown()
        for node in nodes:
            node.destroy_node()
        with contextlib.suppress(Exception):
            rclpy.shutdown()


# --------------------------------------------------------------------------- the benchmark


def cpu_seconds(pid: int) -> float:
    """User plus system CPU time of a process so far (s), all its threads (``/proc``)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@dataclass
class NodeProcess:
    """One process of the benchmark holding one or more bare nodes."""

    label: str
    roles: tuple[str, ...]
    process: subprocess.Popen[str]
    replies: queue.Queue[dict[str, Any] | None] = field(default_factory=queue.Queue)
    output: deque[str] = field(default_factory=lambda: deque(maxlen=20))

    def send(self, command: str) -> None:
        """One command line to the process (ignored once it has gone)."""
        stdin = self.process.stdin
        if stdin is None or self.process.poll() is not None:
            return
        with contextlib.suppress(BrokenPipeError, OSError, ValueError):
            stdin.write(command + "\n")
            stdin.flush()

    def reply(self, kind: str, timeout_s: float) -> dict[str, Any]:
        """The next answer of ``kind``.

        Raises:
            FloorError: the process ended, or did not answer within ``timeout_s``.
        """
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                message = self.replies.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                raise FloorError(
                    f"{self.label} did not answer '{kind}' within {timeout_s:g} s"
                    f"{self._last_words()}"
                ) from None
            if message is None:
                status = self.process.wait()
                raise FloorError(f"{self.label} exited with status {status}{self._last_words()}")
            if message.get("kind") == kind:
                if message.get("error"):
                    raise FloorError(f"{self.label}: {message['error']}")
                return message

    def _last_words(self) -> str:
        lines = [line for line in self.output if line.strip()]
        return f" ({lines[-1].strip()})" if lines else ""

    def cpu_seconds(self) -> float:
        """Its CPU time so far (s)."""
        try:
            return cpu_seconds(self.process.pid)
        except (OSError, IndexError) as err:
            raise FloorError(f"{self.label}: cannot read its CPU time: {err}") from err


def _read_stdout(node: NodeProcess) -> None:
    assert node.process.stdout is not None
    for line in node.process.stdout:
        if line.startswith(MARK):
            node.replies.put(json.loads(line[len(MARK) :]))
        else:
            node.output.append(line)
    node.replies.put(None)


def _read_stderr(node: NodeProcess) -> None:
    assert node.process.stderr is not None
    for line in node.process.stderr:
        node.output.append(line)


@contextlib.contextmanager
def node_processes(
    groups: Sequence[tuple[str, tuple[str, ...]]], env: Mapping[str, str], start_timeout_s: float
) -> Iterator[list[NodeProcess]]:
    """Start one process per group of roles; on leaving (also on Ctrl-C) stop them all."""
    started: list[NodeProcess] = []
    try:
        for label, roles in groups:
            command = [
                sys.executable,
                str(Path(__file__).resolve()),
                "--node",
                ",".join(roles),
                "--start-timeout",
                str(start_timeout_s),
            ]
            process = subprocess.Popen(
                command,
                env=dict(env),
                cwd=PROJECT,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                bufsize=1,
                start_new_session=True,  # Ctrl-C reaches the benchmark, which stops them
            )
            node = NodeProcess(label, roles, process)
            started.append(node)
            for reader in (_read_stdout, _read_stderr):
                threading.Thread(target=reader, args=(node,), daemon=True).start()
        yield started
    finally:
        _stop_all(started)


def _stop_all(nodes: Sequence[NodeProcess]) -> None:
    """``exit`` and end of input; then SIGTERM, then SIGKILL, to these processes only."""
    for node in nodes:
        node.send("exit")
        if node.process.stdin is not None:
            with contextlib.suppress(OSError, ValueError):
                node.process.stdin.close()
    deadline = time.monotonic() + 10.0
    for node in nodes:
        for sig in (None, signal.SIGTERM, signal.SIGKILL):
            if node.process.poll() is not None:
                break
            if sig is not None:
                node.process.send_signal(sig)
            try:
                node.process.wait(max(0.5, deadline - time.monotonic()) if sig is None else 5.0)
            except subprocess.TimeoutExpired:
                continue


@dataclass
class Snapshot:
    """Counts of every node and CPU of every process at one moment."""

    nodes: dict[str, dict[str, Any]]  # role -> counts
    node_time: dict[str, float]  # role -> its process's monotonic time of the counts (s)
    cpu: dict[str, float]  # process label -> CPU seconds
    wall: float  # monotonic (s), when the CPU was read


def snapshot(processes: Sequence[NodeProcess], kind: str = "snapshot") -> Snapshot:
    """Ask every process for its counts and read its CPU time."""
    for node in processes:
        node.send(kind)
    cpu = {node.label: node.cpu_seconds() for node in processes}
    wall = time.monotonic()
    nodes: dict[str, dict[str, Any]] = {}
    node_time: dict[str, float] = {}
    for node in processes:
        reply = node.reply(kind, 10.0)
        for role, counts in reply["nodes"].items():
            if counts.get("error"):
                raise FloorError(f"{role}: {counts['error']}")
            nodes[role] = counts
            node_time[role] = float(reply["t"])
    return Snapshot(nodes, node_time, cpu, wall)


def published_per_topic(nodes: Mapping[str, Mapping[str, Any]]) -> dict[str, int]:
    """How many messages each topic's writer published."""
    published: dict[str, int] = {}
    for counts in nodes.values():
        published.update(counts["published"])
    return published


def missing(nodes: Mapping[str, Mapping[str, Any]]) -> dict[tuple[str, str], int]:
    """(role, topic) -> messages published on the topic that the role has not received."""
    published = published_per_topic(nodes)
    return {
        (role, topic): published[topic] - received
        for role, counts in nodes.items()
        for topic, received in counts["received"].items()
        if published.get(topic, 0) != received
    }


def settle(processes: Sequence[NodeProcess]) -> Snapshot:
    """Stop the source, then give the subscribers time to receive what is still in flight."""
    final = snapshot(processes, "stop")
    began = quiet_since = time.monotonic()
    left = missing(final.nodes)
    while left and time.monotonic() - quiet_since < SETTLE_QUIET_S:
        if time.monotonic() - began > SETTLE_MAX_S:
            break
        time.sleep(0.25)
        final = snapshot(processes)
        now_left = missing(final.nodes)
        if now_left != left:
            quiet_since = time.monotonic()
        left = now_left
    return final


@dataclass
class VariantResult:
    """What one variant measured."""

    variant: str
    groups: list[tuple[str, tuple[str, ...]]]
    window_s: float
    cpu_percent: dict[str, float]  # process label -> % of one core
    rates: dict[str, dict[str, dict[str, float]]]  # role -> published/received -> topic -> /s
    window_counts: dict[str, dict[str, dict[str, int]]]
    lost: dict[tuple[str, str], int]  # (role, topic) -> lost messages (whole run)
    late_ticks: int
    slots_passed_over: int
    executor: str
    load: float

    @property
    def total_percent(self) -> float:
        """CPU of all processes together (% of one core)."""
        return sum(self.cpu_percent.values())


def _groups(variant: str) -> list[tuple[str, tuple[str, ...]]]:
    if variant == "separate":
        return [(role, (role,)) for role in ROLES]
    return [("one process", ROLES)]


def run_variant(
    variant: str, seconds: float, warmup_s: float, start_timeout_s: float
) -> VariantResult:
    """Start the variant's processes, measure the window, count losses; a VariantResult."""
    env = ros_environment()
    groups = _groups(variant)
    with node_processes(groups, env, start_timeout_s) as processes:
        executors = {
            node.reply("ready", start_timeout_s + 30.0).get("executor", "?") for node in processes
        }
        time.sleep(warmup_s)
        first = snapshot(processes)
        time.sleep(seconds)
        last = snapshot(processes)
        final = settle(processes)
    window_s = last.wall - first.wall
    cpu = {label: 100.0 * (last.cpu[label] - first.cpu[label]) / window_s for label in first.cpu}
    counts: dict[str, dict[str, dict[str, int]]] = {}
    rates: dict[str, dict[str, dict[str, float]]] = {}
    for role in ROLES:
        span = last.node_time[role] - first.node_time[role]
        counts[role] = {
            way: {
                topic: last.nodes[role][way][topic] - first.nodes[role][way][topic]
                for topic in last.nodes[role][way]
            }
            for way in ("published", "received")
        }
        rates[role] = {
            way: {topic: count / span for topic, count in per_topic.items()}
            for way, per_topic in counts[role].items()
        }
    silent = [
        (role, topic)
        for role in ROLES
        for topic, count in counts[role]["received"].items()
        if count == 0
    ]
    if silent:
        role, topic = silent[0]
        raise FloorError(
            f"{variant}: {role} received nothing on {topic} in the {window_s:.1f} s window"
            f" ({len(silent)} topic(s) of the nodes silent)"
        )
    source = final.nodes["source"]
    return VariantResult(
        variant=variant,
        groups=groups,
        window_s=window_s,
        cpu_percent=cpu,
        rates=rates,
        window_counts=counts,
        lost={key: value for key, value in missing(final.nodes).items() if value > 0},
        late_ticks=int(source.get("late_ticks", 0)),
        slots_passed_over=int(source.get("slots_passed_over", 0)),
        executor=", ".join(sorted(executors)),
        load=os.getloadavg()[0],
    )


# --------------------------------------------------------------------------- printing


def _per_topic(rates: Mapping[str, float]) -> str:
    if not rates:
        return "-"
    low, high = min(rates.values()), max(rates.values())
    spread = f"{low:.1f}" if f"{low:.1f}" == f"{high:.1f}" else f"{low:.1f}-{high:.1f}"
    return f"{len(rates)} x {spread}/s"


def print_variant(result: VariantResult, warmup_s: float) -> None:
    """The table of one variant: CPU, messages per topic, losses, against the goal."""
    title = {
        "separate": "separate processes (each node its own process, as the chain runs)",
        "one-process": "one process (the four nodes in one executor: intraprocess delivery)",
    }[result.variant]
    print(
        f"\n{title}\n{result.window_s:.1f} s window after {warmup_s:g} s warm-up; executor "
        f"{result.executor}; load average {result.load:.1f}"
    )
    print(f"{'node':20s}{'CPU %':>8s}  {'published per topic':24s}{'received per topic':24s}lost")
    one_each = {roles[0]: label for label, roles in result.groups if len(roles) == 1}
    for role in ROLES:
        label = one_each.get(role)
        cpu = f"{result.cpu_percent[label]:8.1f}" if label is not None else f"{'':8s}"
        lost = sum(n for (who, _), n in result.lost.items() if who == role)
        received = result.rates[role]["received"]
        print(
            f"{role:20s}{cpu}  {_per_topic(result.rates[role]['published']):24s}"
            f"{_per_topic(received):24s}{lost if received else '-'}"
        )
    total = result.total_percent
    verdict = "over" if total >= GOAL_PERCENT else "under"
    where = " (one process)" if len(result.groups) == 1 else ""
    print(
        f"{'total' + where:20s}{total:8.1f}  goal {GOAL_PERCENT:g} %: {verdict} by "
        f"{abs(total - GOAL_PERCENT):.1f} points"
    )
    if result.late_ticks or result.slots_passed_over:
        print(
            f"source, since its start: {result.late_ticks} ticks woke 1 ms or more late, "
            f"{result.slots_passed_over} slots published late in a burst"
        )
    for (role, topic), count in sorted(result.lost.items()):
        print(f"LOST: {role} did not receive {count} messages of {topic}")


# --------------------------------------------------------------------------- main


def _terminate(signum: int, frame: object) -> None:
    del signum, frame
    raise KeyboardInterrupt


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line."""
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0] if __doc__ else None,
        epilog="Each variant: start-up (up to --start-timeout), --warmup, --seconds, then up "
        f"to {SETTLE_MAX_S:g} s for in-flight messages.",
    )
    parser.add_argument(
        "--seconds", type=float, default=20.0, help="window measured (s; default 20)"
    )
    parser.add_argument(
        "--variant",
        choices=("separate", "one-process", "both"),
        default="both",
        help="each node its own process, all four in one process, or both (default)",
    )
    parser.add_argument(
        "--warmup",
        type=float,
        default=5.0,
        help="after the first sample, before the window (s; default 5)",
    )
    parser.add_argument(
        "--start-timeout",
        type=float,
        default=60.0,
        help="how long a node may take to start and find its readers (s; default 60)",
    )
    parser.add_argument("--node", help=argparse.SUPPRESS)  # internal: run these bare nodes
    args = parser.parse_args(argv)
    if args.seconds <= 0 or args.warmup < 0 or args.start_timeout <= 0:
        parser.error("--seconds and --start-timeout must be > 0, --warmup >= 0")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    """Run the variants asked for and print their tables."""
    args = parse_args(argv)
    if args.node is not None:
        return serve(args.node.split(","), args.start_timeout)
    env = ros_environment()
    if env.get("BRAKE_HIL_DDS_PROFILE") != "loopback":
        print(
            f"{NAME}: error: the nodes would not run on the project's loopback profile "
            "(BRAKE_HIL_DDS_PROFILE=off, a Fast DDS profile of your own, or another "
            "RMW_IMPLEMENTATION is set): unset it",
            file=sys.stderr,
        )
        return 2
    problem = security_problem(env)
    if problem is not None:
        print(f"{NAME}: error: {problem}", file=sys.stderr)
        return 2
    signal.signal(signal.SIGINT, signal.default_int_handler)  # also when started with it ignored
    signal.signal(signal.SIGTERM, _terminate)
    variants = ("separate", "one-process") if args.variant == "both" else (args.variant,)
    results: list[VariantResult] = []
    try:
        for variant in variants:
            result = run_variant(variant, args.seconds, args.warmup, args.start_timeout)
            results.append(result)
            print_variant(result, args.warmup)
    except FloorError as err:
        print(f"{NAME}: error: {err}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"{NAME}: interrupted; node processes stopped", file=sys.stderr)
        return 130
    print(f"\nCPU % of one core at 1 kHz, goal {GOAL_PERCENT:g} %:")
    for result in results:
        lost = sum(result.lost.values())
        print(
            f"  {result.variant:12s}{result.total_percent:7.1f} %"
            f"  ({'over' if result.total_percent >= GOAL_PERCENT else 'under'} the goal; "
            f"{lost} messages lost)"
        )
    return 1 if any(result.lost for result in results) else 0


if __name__ == "__main__":
    sys.exit(main())
