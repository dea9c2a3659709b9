"""The chain's node processes: start one node or a container, read its CPU time, stop it.

Each node runs as ``python -m brake_hil.nodes.<name> --ros-args --params-file <file>`` in its
own session (a Ctrl-C reaches the launcher only, which then stops the nodes in order), its
output in ``<workdir>/<name>.log``. No rclpy.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
import os
from pathlib import Path
import signal
import subprocess
import sys
import time
from typing import Any

import yaml

from brake_hil.runtime import set_realtime_priority

__all__ = [
    "CONTAINER",
    "RECORDER_CATCH_UP_S",
    "RECORDER_QUIET_S",
    "NodeProcess",
    "bag_bytes",
    "start_container",
    "start_node",
    "stop_node",
    "thread_cpu_seconds",
    "wait_for_file",
    "wait_until_quiet",
]

CONTAINER = "container"
"""The name of the one-process chain's process (``brake_hil.nodes.container``)."""
RECORDER_QUIET_S = 2.0
"""The recorder has caught up when its files have not grown for this long (s)."""
RECORDER_CATCH_UP_S = 60.0
"""At most this long the launcher waits for a lagging recorder before it stops it (s)."""


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


def wait_for_file(path: Path, node: NodeProcess, timeout_s: float, poll_s: float = 0.1) -> bool:
    """Wait until ``path`` exists (at most ``timeout_s``, or until ``node`` exits)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if path.exists():
            return True
        if node.returncode() is not None:
            return path.exists()
        time.sleep(poll_s)
    return False


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
