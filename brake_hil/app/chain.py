"""The node chain as separate processes: source -> caliper model -> comparator -> recorder.

What ``ros2 launch`` would do, without a ROS install: each node is started as
``python -m brake_hil.nodes.<name> --ros-args --params-file <file>`` with
``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and one ``ROS_DOMAIN_ID`` for the run, in its own
session (a Ctrl-C reaches the launcher only, which then stops the nodes in order). The
source replays the recording once and exits (``exit_at_end``) after waiting for the model,
comparator and recorder to subscribe; the launcher then gives the model and comparator a
moment to finish, and stops them and the recorder with SIGINT. :func:`run_chain` returns the
comparator's run summary, the model's timing, where the MCAP is, and the recorded predictions
checked against the batch model on the recorded input; it prints nothing (the command line,
``python -m brake_hil.nodes.chain``, is :mod:`brake_hil.cli.chain`).

The ``layout`` says which nodes share a process (:data:`LAYOUTS`): ``processes`` (each its
own, as above), ``one-process`` (the four in one process, ``python -m
brake_hil.nodes.container``: one rclpy context, Fast DDS delivers between them inside the
process), ``model-apart`` (the source, comparator and recorder in one process, the caliper
model in its own: its 1 kHz loop shares no GIL, the other three no loopback traffic),
``two-process`` (the source and the model in one process, the comparator and the recorder in
another) or ``paired`` (as ``two-process``, with the model stepped on the source's thread right
after each sample: one thread for the two 1 kHz loops). Each node
gets the same parameters from its own params file, started with the same environment; with a
container the launcher waits for the source's statistics file (written as its replay ends)
instead of the source's exit, and stops the container with SIGINT, which stops its nodes in the
same order (the recorder once it has caught up). Exit codes and CPU time are then the
container's (``ChainResult.exit_codes["container"]``). CPU and loop timing of each layout: the
README (``benchmarks/bench_cpu.py``, ``benchmarks/bench_soak.py``).

This module imports no rclpy: the nodes run in their own processes. The recorder is
optional: without ``brake_hil/nodes/recorder.py`` the chain runs without it and says so.
Node logs go to ``DIR/logs/``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
import importlib.util
import json
import os
from pathlib import Path
import signal
import subprocess
import sys
import time
from typing import Any

import numpy as np
import yaml

from brake_hil.errors import BrakeHilError, DdsSecurityError, RecordingError
from brake_hil.io.recording_reader import list_topics, read_recording
from brake_hil.live.model_file import load_model
from brake_hil.physics.excitation import PulsingSchedule
from brake_hil.runtime import loopback_environment, security_problem, set_realtime_priority
from brake_hil.topics import (
    AIR_PRESSURE,
    MASTER_CYLINDER_PRESSURE,
    MEASURED_OUTPUTS,
    OUTPUT_CHANNELS,
    PREDICTED_OUTPUTS,
)

__all__ = [
    "DEFAULT_MODEL",
    "LAYOUTS",
    "LAYOUT_PARAMETERS",
    "DEFAULT_RECORDING",
    "PROJECT",
    "SOURCE_MARGIN_S",
    "ChainResult",
    "NodeProcess",
    "Notice",
    "check_recorded_predictions",
    "choose_domain_id",
    "node_available",
    "ros_environment",
    "run_can_chain",
    "run_chain",
    "start_container",
    "start_layout",
    "start_node",
    "stop_node",
    "thread_cpu_seconds",
    "wait_until_quiet",
]

SOURCE_MARGIN_S = 60.0
"""How long past the replay's own length the source is given to end (s): its wait for its
subscribers (at most 30 s), its start delay (1 s) and its wait for their acknowledgements at
the end (``common.ACK_WAIT_AT_END_S``, 20 s)."""

PROJECT = Path(__file__).resolve().parents[2]
DEFAULT_RECORDING = PROJECT / "bags" / "one_washer_lti"
DEFAULT_MODEL = PROJECT / "config" / "rig_default.yaml"
CONTAINER = "container"
"""The name of the one-process chain's process (``brake_hil.nodes.container``)."""
NODE_ORDER = ("recorder", "comparator", "caliper_model", "pressure_source")
"""The chain's nodes in start order (readers before their writers)."""
REALTIME_GROUP = "container-realtime"
CONSUMERS_GROUP = "container-consumers"
_LOOPS_APART_FROM_CONSUMERS = {
    "recorder": CONSUMERS_GROUP,
    "comparator": CONSUMERS_GROUP,
    "caliper_model": REALTIME_GROUP,
    "pressure_source": REALTIME_GROUP,
}
LAYOUTS: dict[str, dict[str, str]] = {
    "processes": {},
    "one-process": dict.fromkeys(NODE_ORDER, CONTAINER),
    "model-apart": dict.fromkeys(("recorder", "comparator", "pressure_source"), CONTAINER),
    "two-process": _LOOPS_APART_FROM_CONSUMERS,
    "paired": _LOOPS_APART_FROM_CONSUMERS,
}
"""Which nodes share a process: node name -> the container's process name; a node not named
runs in its own process. ``two-process``: the source and the model (the 1 kHz loops) in one,
the comparator and the recorder in another; ``paired``: as ``two-process``, the model stepped
on the source's thread (:data:`LAYOUT_PARAMETERS`)."""
LAYOUT_PARAMETERS: dict[str, dict[str, dict[str, Any]]] = {
    "paired": {"caliper_model": {"paired_with_source": True}},
}
"""Node parameters a layout sets (over the plan's): layout -> node -> parameters."""
CONTAINER_STOP_S = 100.0
"""How long the launcher gives the container to stop after SIGINT (s): the source's and the
model's wait for acknowledgements (8 s each) and the recorder's catch-up (at most 60 s)."""


def ros_environment(domain_id: int | None = None) -> dict[str, str]:
    """The environment of a node process: DDS on loopback, the run's domain.

    Local-only: the project's loopback profile unless the user set a Fast DDS profile of
    their own (:func:`brake_hil.runtime.loopback_environment`).
    """
    env = dict(os.environ)
    if env.get("BRAKE_HIL_DDS_PROFILE") != "loopback":
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    loopback_environment(env)
    env["ROS_DOMAIN_ID"] = str(choose_domain_id() if domain_id is None else domain_id)
    env["PYTHONUNBUFFERED"] = "1"
    return env


def _check_security(env: Mapping[str, str]) -> None:
    problem = security_problem(dict(env))
    if problem is not None:
        raise DdsSecurityError(problem)


def choose_domain_id() -> int:
    """A domain id (1-100) unlikely to be shared with another run on this host."""
    return 1 + (os.getpid() * 7919 + time.time_ns() // 1_000_000) % 100


def node_available(name: str) -> bool:
    """True when ``brake_hil.nodes.<name>`` exists."""
    return importlib.util.find_spec(f"brake_hil.nodes.{name}") is not None


@dataclass
class NodeProcess:
    """One running node."""

    name: str
    process: subprocess.Popen[bytes]
    log: Path
    nodes: tuple[str, ...] = ()
    """The nodes a container runs (empty: the process is the node ``name``)."""

    @property
    def is_container(self) -> bool:
        """True for a ``brake_hil.nodes.container`` process."""
        return bool(self.nodes)

    def runs(self, node: str) -> bool:
        """True when ``node`` runs in this process."""
        return node in self.nodes if self.nodes else node == self.name

    def returncode(self) -> int | None:
        """Exit status, None while running."""
        return self.process.poll()

    def cpu_seconds(self) -> float | None:
        """User plus system CPU time so far (s), None once it has exited (Linux /proc)."""
        try:
            fields = Path(f"/proc/{self.process.pid}/stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            return None
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def thread_cpu_seconds(self) -> dict[str, float]:
        """CPU time (s) of each thread so far, by kernel name (``comm``), equal names summed.

        Empty once it has exited (Linux ``/proc/PID/task``). The container names the nodes'
        threads (``model-loop``, ``comparator-loop``, ...: :mod:`brake_hil.nodes.container`).
        """
        ticks = os.sysconf("SC_CLK_TCK")
        seconds: dict[str, float] = {}
        try:
            tasks = list(Path(f"/proc/{self.process.pid}/task").iterdir())
        except OSError:
            return seconds
        for task in tasks:
            try:
                comm = (task / "comm").read_text().strip()
                fields = (task / "stat").read_text().rsplit(")", 1)[1].split()
            except (OSError, IndexError):
                continue
            seconds[comm] = seconds.get(comm, 0.0) + (int(fields[11]) + int(fields[12])) / ticks
        return seconds


def start_node(
    name: str,
    parameters: Mapping[str, Any],
    env: Mapping[str, str],
    workdir: Path,
    fifo_priority: int = 0,
) -> NodeProcess:
    """Start ``brake_hil.nodes.<name>`` with ``parameters`` (written to a params file).

    ``fifo_priority`` > 0 starts the whole process under ``SCHED_FIFO`` at that priority (as
    ``chrt -f`` would; needs CAP_SYS_NICE, else the node runs normally).
    """
    params = _params_file(name, parameters, workdir)
    log = workdir / f"{name}.log"
    command = [
        sys.executable,
        "-m",
        f"brake_hil.nodes.{name}",
        "--ros-args",
        "--params-file",
        str(params),
    ]
    return NodeProcess(name, _spawn(command, env, log, fifo_priority), log)


def _params_file(name: str, parameters: Mapping[str, Any], workdir: Path) -> Path:
    workdir.mkdir(parents=True, exist_ok=True)
    params = workdir / f"{name}.params.yaml"
    params.write_text(
        yaml.safe_dump({name: {"ros__parameters": dict(parameters)}}), encoding="utf-8"
    )
    return params


def thread_cpu_seconds(processes: Sequence[NodeProcess]) -> dict[str, float]:
    """CPU time (s) of each thread name so far, summed over ``processes`` (their ``/proc``)."""
    seconds: dict[str, float] = {}
    for process in processes:
        for comm, value in process.thread_cpu_seconds().items():
            seconds[comm] = seconds.get(comm, 0.0) + value
    return seconds


def start_container(
    nodes: Sequence[tuple[str, Mapping[str, Any]]],
    env: Mapping[str, str],
    workdir: Path,
    fifo_priority: int = 0,
    name: str = CONTAINER,
) -> NodeProcess:
    """Start ``brake_hil.nodes.container`` running ``nodes`` (name, parameters), in that order.

    Each node's parameters go to its own params file, as :func:`start_node` writes them; the
    process is started as :func:`start_node` starts a node (own session, log ``NAME.log``).
    ``fifo_priority`` > 0: the whole process under ``SCHED_FIFO``.
    """
    command = [sys.executable, "-m", f"brake_hil.nodes.{CONTAINER}"]
    for node, parameters in nodes:
        params = _params_file(node, parameters, workdir)
        command += ["--node", node, "--ros-args", "--params-file", str(params)]
    log = workdir / f"{name}.log"
    process = _spawn(command, env, log, fifo_priority)
    return NodeProcess(name, process, log, tuple(node for node, _ in nodes))


def _spawn(
    command: Sequence[str], env: Mapping[str, str], log: Path, fifo_priority: int
) -> subprocess.Popen[bytes]:
    """Start ``command`` in its own session, output to ``log``, ``SCHED_FIFO`` if > 0."""
    with log.open("wb") as stream:
        return subprocess.Popen(
            list(command),
            env=dict(env),
            stdout=stream,
            stderr=subprocess.STDOUT,
            start_new_session=True,
            preexec_fn=(lambda: set_realtime_priority(fifo_priority)) if fifo_priority else None,
        )


def start_layout(
    plan: Sequence[tuple[str, Mapping[str, Any]]],
    env: Mapping[str, str],
    workdir: Path,
    layout: str = "processes",
    fifo_priority: Mapping[str, int] | None = None,
) -> list[NodeProcess]:
    """Start the nodes of ``plan`` (name, parameters; readers first) as ``layout`` says.

    A process is started when its first node's turn in ``plan`` comes (a container with all
    its nodes, in plan order). ``fifo_priority``: per node name, a ``SCHED_FIFO`` priority for
    a node in its own process (:func:`start_node`); containers start normally (their loop
    threads raise themselves: the nodes' ``realtime_priority``; a whole container under
    ``SCHED_FIFO``, tried, took more CPU, 60 against 47 % of a core, for no better timing).
    Returns the processes in start order.

    Raises:
        ValueError: an unknown layout.
    """
    if layout not in LAYOUTS:
        raise ValueError(f"unknown layout {layout!r} (layouts: {', '.join(LAYOUTS)})")
    priorities = dict(fifo_priority or {})
    groups = LAYOUTS[layout]
    overrides = LAYOUT_PARAMETERS.get(layout, {})
    plan = [(name, {**parameters, **overrides.get(name, {})}) for name, parameters in plan]
    processes: list[NodeProcess] = []
    for name, parameters in plan:
        group = groups.get(name)
        if group is None:
            processes.append(start_node(name, parameters, env, workdir, priorities.get(name, 0)))
        elif not any(process.name == group for process in processes):
            members = [(node, values) for node, values in plan if groups.get(node) == group]
            processes.append(start_container(members, env, workdir, name=group))
    return processes


def stop_node(node: NodeProcess, timeout_s: float = 10.0) -> int:
    """SIGINT, then SIGTERM, then SIGKILL, each after ``timeout_s``; the exit status."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
        if node.process.poll() is not None:
            break
        node.process.send_signal(sig)
        try:
            node.process.wait(timeout_s)
        except subprocess.TimeoutExpired:
            continue
    return node.process.wait()


@dataclass(frozen=True)
class ChainResult:
    """What a chain run produced."""

    out_dir: Path
    comparator: dict[str, Any] | None = None  # comparator summary
    model: dict[str, Any] | None = None  # caliper model timing statistics
    bag: Path | None = None  # the recorder's MCAP directory
    check: dict[str, float] | None = None  # recorded predictions against the batch model
    missing: tuple[str, ...] = ()  # nodes not available
    exit_codes: dict[str, int] = field(default_factory=dict)
    cpu_s: dict[str, float] = field(default_factory=dict)  # CPU time of each node (s)
    wall_s: float = 0.0  # from the source's start to the stop (s)
    logs: Path | None = None  # the nodes' log files
    source: dict[str, Any] | None = None  # pressure source summary
    expected: int | None = None  # input samples the source was to publish (None: unknown)

    @property
    def failed(self) -> dict[str, int]:
        """Nodes that exited with a non-zero status, and the status."""
        return {name: code for name, code in self.exit_codes.items() if code != 0}

    def sample_losses(self) -> tuple[bool, str]:
        """Whether every input sample was predicted and recorded, and one line saying so.

        Counts the source's published ``p_i`` samples against the run's (``expected``: a
        source stopped before the end of its run, by a timeout on a starved machine, is a
        failure), the model's predictions and, with a recording, the recorded inputs and
        predictions. Without the source's or the model's summary nothing can be said: that is a
        failure too ("I don't know").
        """
        if self.source is None or self.model is None:
            absent = [n for n, d in (("source", self.source), ("model", self.model)) if d is None]
            absent_text = " or ".join(absent)
            return False, f"cannot tell whether samples were lost: no {absent_text} summary"
        published = int(self.source["published"])
        predictions = int(self.model["counters"]["predictions"])
        unpredicted = published - predictions
        short = self.expected is not None and published != self.expected
        of_run = f" of the run's {self.expected}" if short else ""
        parts = [f"{published}{of_run} samples published, {predictions} predicted"]
        parts[0] += f" ({unpredicted} unpredicted)" if unpredicted else ""
        lost = 0
        if self.check is not None:
            inputs, recorded = int(self.check["inputs"]), int(self.check["predictions"])
            lost = (published - inputs) + (predictions - recorded)
            parts.append(f"{inputs} inputs and {recorded} predictions recorded ({lost} lost)")
        elif self.bag is not None:
            return False, f"{parts[0]}; the recording could not be checked"
        whole = unpredicted == 0 and lost == 0
        verdict = "every sample predicted and recorded" if whole else "samples were lost"
        if short and whole:
            verdict = "the run was cut short"
        ok = whole and not short
        return ok, f"{verdict}: " + "; ".join(parts)


Notice = Callable[[str], None]
"""Called with a one-line notice while the chain runs (what it starts, what went wrong)."""


@dataclass
class _Stops:
    """What stopping the nodes measured (filled as each node stops)."""

    exit_codes: dict[str, int] = field(default_factory=dict)
    cpu_s: dict[str, float] = field(default_factory=dict)


def _ignore(message: str) -> None:
    """A notice nobody reads."""


def run_chain(
    recording: Path,
    model_file: Path = DEFAULT_MODEL,
    out_dir: Path = PROJECT / "out" / "chain",
    rate: float = 1.0,
    domain_id: int | None = None,
    progress: Notice | None = None,
    recorder: bool = True,
    realtime_priority: int = 0,
    layout: str = "processes",
) -> ChainResult:
    """Run the chain on ``recording`` once; see the module docstring.

    Args:
        recording: the recording the source replays (``p_i`` and the measured outputs).
        model_file: the caliper model's model file (rig YAML or ``improved_model.json``).
        out_dir: summaries, the MCAP and ``logs/`` go here.
        rate: replay rate factor.
        domain_id: ``ROS_DOMAIN_ID`` of the run (``None``: one chosen for it).
        progress: called with each notice while the chain runs.
        recorder: record the run to MCAP (when the recorder node exists).
        realtime_priority: ``SCHED_FIFO`` priority of the source's and the model's loop
            threads (0: none).
        layout: which nodes share a process (:data:`LAYOUTS`).

    Returns:
        What the nodes left: summaries, exit codes, CPU times, the checked recording.

    Raises:
        BrakeHilError: a bad recording or model file (before any node starts).
    """
    say = progress or _ignore
    if layout not in LAYOUTS:
        raise BrakeHilError(f"unknown layout {layout!r} (layouts: {', '.join(LAYOUTS)})")
    source = read_recording(recording, required=(MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS))
    mean_pressure = float(np.mean(source.master_cylinder_pressure))
    load_model(model_file, mean_pressure)  # a bad model file fails here, with one line
    length_s = float(source.time[-1])
    env = ros_environment(domain_id)
    _check_security(env)
    logs = out_dir / "logs"
    missing: tuple[str, ...] = ()
    has_recorder = recorder and node_available("recorder")
    if recorder and not has_recorder:
        missing = ("recorder",)
        say("recorder node not available: running without recording")
    bag_name = "chain_" + datetime.now(UTC).strftime("%Y_%m_%d-%H_%M_%S")
    subscribers = 2 if has_recorder else 1
    nodes: list[NodeProcess] = []
    stops = _Stops()
    wall_s = 0.0
    say(
        f"chain on {recording} ({length_s:.1f} s at rate {rate:g}), model {model_file}, "
        f"ROS_DOMAIN_ID {env['ROS_DOMAIN_ID']}"
        + ("" if layout == "processes" else f", layout {layout}")
    )
    # In start order: readers before their writers (the launcher stops them in reverse).
    plan: list[tuple[str, dict[str, Any]]] = []
    if has_recorder:
        plan.append(("recorder", {"output_dir": str(out_dir), "bag_name": bag_name}))
    plan.append(("comparator", {"summary_file": str(out_dir / "comparator.json")}))
    model_parameters = {
        "model_file": str(model_file),
        "mean_pressure": mean_pressure,
        "statistics_file": str(out_dir / "caliper_model.json"),
        "realtime_priority": realtime_priority,
        "wait_for_subscribers": subscribers,  # comparator (and recorder) matched first
    }
    plan.append(("caliper_model", model_parameters))
    source_parameters = {
        "recording": str(recording),
        "statistics_file": str(out_dir / "pressure_source.json"),
        "rate": float(rate),
        "exit_at_end": True,
        "wait_for_subscribers": 0,
        "wait_for_topics": _source_waits(subscribers)
        + ([f"{AIR_PRESSURE.name}:1"] if has_recorder and source.air_pressure is not None else []),
        "wait_timeout": 30.0,
        "start_delay": 1.0,
        "realtime_priority": realtime_priority,
    }
    plan.append(("pressure_source", source_parameters))
    source_done = out_dir / "pressure_source.json"  # written as the source ends
    source_done.unlink(missing_ok=True)
    try:
        if "pressure_source" in LAYOUTS[layout]:  # the source runs in a container
            nodes.extend(start_layout(plan, env, logs, layout))
            container = next(node for node in nodes if node.runs("pressure_source"))
            started = time.monotonic()
            if not _wait_for_file(source_done, container, length_s / rate + SOURCE_MARGIN_S):
                code = container.returncode()
                say(
                    f"pressure_source did not finish in time: stopping {container.name}"
                    if code is None
                    else f"{container.name} exited with status {code} before the source finished"
                )
        else:
            for name, parameters in plan:
                nodes.append(start_node(name, parameters, env, logs))
            player = nodes[-1]
            started = time.monotonic()
            try:
                player.process.wait(length_s / rate + SOURCE_MARGIN_S)
            except subprocess.TimeoutExpired:
                say("pressure_source did not finish in time: stopping it")
        time.sleep(1.0)  # the model drains, the comparator scores its last cycle
        wall_s = time.monotonic() - started
    finally:
        _stop_all(nodes, stops, out_dir / bag_name if has_recorder else None)
    return _collect(
        out_dir,
        stops,
        wall_s,
        missing,
        logs,
        bag_name if has_recorder else None,
        model_file,
        mean_pressure,
        say,
        expected=int(source.time.size),
    )


def _source_waits(subscribers: int) -> list[str]:
    """The pressure source's ``wait_for_topics``: each topic's own consumers.

    The model takes p_i, the comparator the measured outputs and the predictions, the recorder
    everything: ``subscribers`` on each (2 with a recorder, 1 without).
    """
    return [
        f"{spec.name}:{subscribers}"
        for spec in (MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS, *PREDICTED_OUTPUTS)
    ]


def _wait_for_file(path: Path, node: NodeProcess, timeout_s: float, poll_s: float = 0.1) -> bool:
    """Wait until ``path`` exists (at most ``timeout_s``, or until ``node`` exits)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if path.exists():
            return True
        if node.returncode() is not None:
            return path.exists()
        time.sleep(poll_s)
    return False


RECORDER_QUIET_S = 2.0
"""The recorder has caught up when its files have not grown for this long (s)."""
RECORDER_CATCH_UP_S = 60.0
"""At most this long the launcher waits for a lagging recorder before it stops it (s)."""


def bag_bytes(bag: Path) -> int:
    """Bytes of every file in ``bag`` (0 when it does not exist yet)."""
    try:
        return sum(entry.stat().st_size for entry in bag.iterdir() if entry.is_file())
    except OSError:
        return 0


def wait_until_quiet(
    bag: Path,
    quiet_s: float = RECORDER_QUIET_S,
    timeout_s: float = RECORDER_CATCH_UP_S,
    poll_s: float = 0.1,
) -> bool:
    """Wait until ``bag`` has not grown for ``quiet_s`` (at most ``timeout_s``); True if so.

    On a busy machine the recorder can lag its publishers by seconds, the backlog held by the
    middleware (the sample topics' deep history); it commits a chunk at least every
    ``flush_interval_s`` while it writes, so files that stop growing mean it has caught up.
    """
    deadline = time.monotonic() + timeout_s
    size, since = bag_bytes(bag), time.monotonic()
    while (now := time.monotonic()) < deadline:
        if now - since >= quiet_s:
            return True
        time.sleep(poll_s)
        if (current := bag_bytes(bag)) != size:
            size, since = current, time.monotonic()
    return False


def _stop_all(nodes: list[NodeProcess], stops: _Stops, bag: Path | None = None) -> None:
    """Stop the nodes, last started first (source, model, comparator, recorder).

    The recorder is stopped once its files stop growing (:func:`wait_until_quiet`); the
    container stops its nodes in that order itself, given :data:`CONTAINER_STOP_S`.
    """
    for node in reversed(nodes):
        if node.name == "recorder" and bag is not None:
            wait_until_quiet(bag)
        cpu = node.cpu_seconds()
        if cpu is not None:
            stops.cpu_s[node.name] = cpu
        timeout_s = CONTAINER_STOP_S if node.is_container else 10.0
        stops.exit_codes[node.name] = stop_node(node, timeout_s)


def _collect(
    out_dir: Path,
    stops: _Stops,
    wall_s: float,
    missing: tuple[str, ...],
    logs: Path,
    bag_name: str | None,
    model_file: Path,
    mean_pressure: float,
    say: Notice,
    expected: int | None = None,
) -> ChainResult:
    """Read what the nodes left (summaries, the bag) and check the bag."""
    failed = {name: code for name, code in stops.exit_codes.items() if code != 0}
    if failed:
        say(f"nodes exited with errors: {failed}; logs in {logs}")
    bag = None
    check = None
    if bag_name is not None and (out_dir / bag_name / "metadata.yaml").is_file():
        bag = out_dir / bag_name
        try:
            check = check_recorded_predictions(bag, model_file, mean_pressure)
        except BrakeHilError as err:
            say(f"the recording cannot be checked: {err}")
    return ChainResult(
        out_dir=out_dir,
        comparator=_read_json(out_dir / "comparator.json"),
        model=_read_json(out_dir / "caliper_model.json"),
        bag=bag,
        check=check,
        missing=missing,
        exit_codes=stops.exit_codes,
        cpu_s=stops.cpu_s,
        wall_s=wall_s,
        logs=logs,
        source=_read_json(out_dir / "pressure_source.json"),
        expected=expected,
    )


def run_can_chain(
    rig_file: Path = DEFAULT_MODEL,
    effects: Sequence[str] = (),
    model_file: Path = DEFAULT_MODEL,
    out_dir: Path = PROJECT / "out" / "chain_can",
    pulsing_s: float = 5.0,
    domain_id: int | None = None,
    progress: Notice | None = None,
) -> ChainResult:
    """The chain against the rig emulator over CAN, without hardware.

    rig_emulator plays a virtual-rig run of ``rig_file`` (with ``effects``) in real time as
    the DBC's CAN frames on an slcan pseudo-terminal; pressure_source reads them as a DAQ
    (mode ``can``) and publishes the measured topics; then model, comparator and recorder as
    in :func:`run_chain`.

    Args:
        rig_file: the truth rig the emulator simulates.
        effects: virtual-rig effects, ``NAME[=STRENGTH]`` each.
        model_file: the caliper model's model file.
        out_dir: summaries, the MCAP, the slcan link and ``logs/`` go here.
        pulsing_s: seconds of 5 Hz pulsing the emulator plays.
        domain_id: ``ROS_DOMAIN_ID`` of the run (``None``: one chosen for it).
        progress: called with each notice while the chain runs.

    Returns:
        What the nodes left, as :func:`run_chain`.

    Raises:
        BrakeHilError: a bad model file (before any node starts).
    """
    say = progress or _ignore
    load_model(model_file, 1.0e6)  # a bad model file fails here, with one line
    env = ros_environment(domain_id)
    _check_security(env)
    logs = out_dir / "logs"
    bag_name = "chain_can_" + datetime.now(UTC).strftime("%Y_%m_%d-%H_%M_%S")
    link = out_dir / "rig_can"
    out_dir.mkdir(parents=True, exist_ok=True)
    link.unlink(missing_ok=True)
    schedule = PulsingSchedule((1.38e6,), pulsing_s=pulsing_s)  # what the emulator plays
    mean_pressure = schedule.segments[0].mean
    nodes: list[NodeProcess] = []
    stops = _Stops()
    wall_s = 0.0
    say(
        f"chain over CAN: rig_emulator ({rig_file}, effects {list(effects) or 'none'}) -> "
        f"slcan {link} -> pressure_source -> model {model_file}, "
        f"ROS_DOMAIN_ID {env['ROS_DOMAIN_ID']}"
    )
    try:
        nodes.append(
            start_node("recorder", {"output_dir": str(out_dir), "bag_name": bag_name}, env, logs)
        )
        nodes.append(
            start_node("comparator", {"summary_file": str(out_dir / "comparator.json")}, env, logs)
        )
        nodes.append(
            start_node(
                "caliper_model",
                {
                    "model_file": str(model_file),
                    "mean_pressure": mean_pressure,
                    "statistics_file": str(out_dir / "caliper_model.json"),
                    "wait_for_subscribers": 2,  # comparator and recorder matched first
                },
                env,
                logs,
            )
        )
        emulator = start_node(
            "rig_emulator",
            {
                "rig_file": str(rig_file),
                "effects": list(effects) or [""],
                "max_pressures": list(schedule.max_pressures),
                "pulsing_s": schedule.pulsing_s,
                "loop": False,
                "output": "can",
                "can_link_path": str(link),
                "wait_for_subscribers": 1,  # the pressure source has opened the pty
                "wait_timeout_s": 60.0,
                "start_delay_s": 1.0,
            },
            env,
            logs,
        )
        nodes.append(emulator)
        nodes.append(
            start_node(
                "pressure_source",
                {
                    "mode": "can",
                    "can_interface": "slcan",
                    "can_channel": str(link),
                    "can_bitrate": 1_000_000,
                    "statistics_file": str(out_dir / "pressure_source.json"),
                    # the emulator starts once this source opens the port: open it only once
                    # the model and the recorder take p_i (discovery can take over a second
                    # on a busy machine: 1047 of 3000 samples went unpredicted once)
                    "wait_for_subscribers": 0,
                    "wait_for_topics": _source_waits(2),
                    "wait_timeout": 30.0,
                },
                env,
                logs,
            )
        )
        started = time.monotonic()
        try:
            emulator.process.wait(pulsing_s + 120.0)
        except subprocess.TimeoutExpired:
            say("rig_emulator did not finish in time: stopping it")
        time.sleep(1.0)
        wall_s = time.monotonic() - started
    finally:
        _stop_all(nodes, stops, out_dir / bag_name)
    return _collect(
        out_dir,
        stops,
        wall_s,
        (),
        logs,
        bag_name,
        model_file,
        mean_pressure,
        say,
        expected=schedule.samples,
    )


def _read_json(path: Path) -> dict[str, Any] | None:
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return document if isinstance(document, dict) else None


def check_recorded_predictions(
    bag: Path, model_file: Path, mean_pressure: float
) -> dict[str, float]:
    """Recorded predictions against the batch model on the recorded ``p_i``.

    Returns the input and prediction counts (from the files' indexes, so a recording that lost
    samples is counted, not refused) and, when they agree, per channel the largest deviation
    over the batch output's peak-to-peak (float rounding: ~1e-13).
    """
    topics = {t.name: t for t in list_topics(bag)}
    missing = [
        spec.name
        for spec in (MASTER_CYLINDER_PRESSURE, PREDICTED_OUTPUTS[0])
        if spec.name not in topics
    ]
    check: dict[str, float] = (
        {
            "inputs": float(topics[MASTER_CYLINDER_PRESSURE.name].message_count),
            "predictions": float(topics[PREDICTED_OUTPUTS[0].name].message_count),
        }
        if not missing
        else {"inputs": 0.0, "predictions": 0.0}
    )
    if missing or check["inputs"] != check["predictions"]:
        return check  # samples missing from the recording: counted, nothing more to compare
    try:
        recorded = read_recording(bag, required=(MASTER_CYLINDER_PRESSURE, *PREDICTED_OUTPUTS))
    except RecordingError:
        return check  # e.g. a gap where both lost the same samples: the counts say it
    batch = load_model(model_file, mean_pressure).batch(recorded.master_cylinder_pressure)
    predicted = (
        recorded.predicted_bore_pressure,
        recorded.predicted_block_force,
        recorded.predicted_caliper_displacement,
    )
    for channel, live, offline in zip(OUTPUT_CHANNELS, predicted, batch):
        assert live is not None
        check[f"max_dev_{channel}"] = float(np.max(np.abs(live - offline)) / np.ptp(offline))
    return check
