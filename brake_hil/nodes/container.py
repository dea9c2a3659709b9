"""The chain's nodes in one process: ``python -m brake_hil.nodes.container``.

What a ROS 2 component container does, for this package's nodes and without a ROS install:
several nodes, one process, one rclpy context (one DDS participant, so Fast DDS delivers
between them inside the process instead of over loopback UDP), each node built with its own
parameters (one command line)::

    python -m brake_hil.nodes.container
        --node recorder --ros-args --params-file recorder.yaml
        --node comparator --ros-args --params-file comparator.yaml
        --node caliper_model --ros-args --params-file caliper_model.yaml
        --node pressure_source --ros-args --params-file pressure_source.yaml

The arguments after ``--node NAME`` (up to the next ``--node``) are that node's own ROS
arguments (rclpy ``Node(cli_args=...)``: ``--params-file``, ``-p name:=value``, ``-r`` remaps);
ROS arguments before the first ``--node`` go to ``rclpy.init`` and so to every node (a params
file keyed by node names gives each node its section, as with ``ros2 run``). Nodes are built in
the order given (readers first, as the launcher starts them); a node may appear once.

Each node runs as in its own process: ``pressure_source`` with an executor of its own on a
background thread (:class:`~brake_hil.nodes.common.BackgroundSpinner`), ``caliper_model``,
``comparator`` and ``recorder`` on their own loop threads. ``realtime_priority`` gives the
source's worker and the model's loop thread ``SCHED_FIFO`` (per thread, as in their own
processes), but not the rest of the process: in their own processes they also raise every
thread of the process (the middleware's), which here would raise the other nodes too. The
threads share one GIL: a priority orders the kernel's scheduling, not who holds the GIL.

The trade-off (``benchmarks/bench_cpu.py``, ``benchmarks/bench_soak.py --layout``; figures in
the README): nodes in one process take far less CPU than as processes (no loopback UDP between
them), but a loop waits for the GIL behind the other nodes' Python work (CPython hands the GIL
over after its 5 ms switch interval), so with all four nodes in one process the model's period
error and latency are milliseconds at p99, with or without ``SCHED_FIFO``. The launcher's
layouts (``python -m brake_hil.nodes.chain --layout``) put some nodes in a container and the
rest in processes of their own (``two-process``: the two 1 kHz loops in one container, the
comparator and the recorder in another).

A ``caliper_model`` with ``paired_with_source`` is stepped by the replaying source's thread
right after each sample it publishes (:func:`pair_source_and_model`): the two 1 kHz loops are
then one thread, with no GIL between them; the model's own loop takes over when the replay
ends. Without a replaying source in the container that is bad parameters (exit 2).

A node whose work ends by itself (the source at the end of a replay with ``exit_at_end``, a
loop that failed, a recorder whose write failed) is closed and destroyed at once, as its
process would exit; the others run on. SIGINT or SIGTERM stops the rest in the order the
launcher stops separate processes: source, model, comparator, then the recorder once it has
recorded nothing new for :data:`RECORDER_QUIET_S` (at most :data:`RECORDER_CATCH_UP_S`; a
second signal cuts that wait short). Every node's ``close()`` and ``destroy_node()`` run,
then ``rclpy.shutdown()``. The process ends when every node has ended.

Exit status: 0 every node healthy; 1 a node failed (its loop or executor stopped on an error,
a failed write); 2 bad arguments or parameters of a node: one line on stderr
(``container: error: NODE: problem``), after closing the nodes already built. The nodes' log
output goes to stdout (``RCUTILS_LOGGING_USE_STDOUT``, unless set), so stderr holds the
container's own lines only. ``-h``/``--help`` prints the usage and exits 0 without starting
ROS.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
import os
from pathlib import Path
import signal
import sys
import threading
import time
from typing import Any

import rclpy
from rclpy.exceptions import ParameterException

from brake_hil.errors import BrakeHilError
from brake_hil.nodes import common
from brake_hil.runtime import security_problem

NAME = "container"
NODE_NAMES = ("pressure_source", "caliper_model", "comparator", "recorder")
"""The nodes a container runs, in the order it stops them (the launcher's order)."""
RECORDER_QUIET_S = 2.0
"""The recorder is stopped once it has recorded nothing new for this long (s)."""
RECORDER_CATCH_UP_S = 60.0
"""At most this long the recorder is given to catch up before it is stopped (s)."""
THREAD_NAMES = {
    "pressure_source": "source-worker",
    "caliper-model-loop": "model-loop",
    "comparator-loop": "comparator-loop",
    "daq-stale": "source-stale",
}
"""Kernel names (``/proc/self/task/*/comm``, what ``top -H`` shows) of the nodes' threads."""

USAGE = f"""usage: python -m brake_hil.nodes.{NAME} [--ros-args ARGS...]
           --node NAME [--ros-args ARGS...] [--node NAME [--ros-args ARGS...]]...

The chain's nodes in one process (one rclpy context): each --node NAME is built with the
ROS arguments that follow it (--params-file FILE, -p name:=value, -r from:=to); ROS
arguments before the first --node apply to every node. Nodes are built in the order given
and stopped by SIGINT/SIGTERM in the launcher's order: source, model, comparator, then the
recorder once it has caught up (a second signal: at once).

nodes: {", ".join(NODE_NAMES)}
  (each at most once; python -m brake_hil.nodes.NAME --help lists its parameters)

exit status: 0 every node healthy, 1 a node failed, 2 bad arguments or parameters (one
line on stderr)."""


class UsageError(ValueError):
    """A command line the container cannot run."""


@dataclass(frozen=True)
class NodeSpec:
    """One ``--node NAME [ARGS...]`` of the command line."""

    name: str
    ros_args: tuple[str, ...]


def parse_command_line(argv: Sequence[str]) -> tuple[tuple[str, ...], tuple[NodeSpec, ...]]:
    """The global ROS arguments and the nodes with their own.

    Raises:
        UsageError: no node, an unknown or repeated node, arguments that are not ROS
            arguments.
    """
    argv = list(argv)
    starts = [index for index, token in enumerate(argv) if token == "--node"]
    if not starts:
        raise UsageError("no --node given (see --help)")
    global_args = tuple(argv[: starts[0]])
    specs: list[NodeSpec] = []
    for begin, end in zip(starts, [*starts[1:], len(argv)]):
        if begin + 1 >= end:
            raise UsageError("--node needs a node name")
        name, rest = argv[begin + 1], tuple(argv[begin + 2 : end])
        if name not in NODE_NAMES:
            raise UsageError(f"unknown node {name!r} (nodes: {', '.join(NODE_NAMES)})")
        if any(spec.name == name for spec in specs):
            raise UsageError(f"node {name} given twice")
        specs.append(NodeSpec(name, rest))
    for owner, args in (("before the first --node", global_args),) + tuple(
        (f"of {spec.name}", spec.ros_args) for spec in specs
    ):
        if args and args[0] != "--ros-args":
            raise UsageError(f"arguments {owner} must start with --ros-args, got {args[0]!r}")
        missing = _missing_files(args)
        if missing:
            raise UsageError(f"{missing}: no such params file ({owner})")
    return global_args, tuple(specs)


def _missing_files(args: Sequence[str]) -> str | None:
    for flag, value in zip(args, args[1:]):
        if flag == "--params-file" and not Path(value).is_file():
            return value
    return None


# --------------------------------------------------------------------------- members


class Member:
    """A node of the container and how it runs: built, watched, finished."""

    def __init__(self, name: str, node: Any, spinner: common.BackgroundSpinner | None) -> None:
        self.name = name
        self.node = node
        self.spinner = spinner
        self.finished = False
        self.healthy = True

    def ended_by_itself(self) -> bool:
        """True when the node's work is over without being asked (as its process would exit)."""
        if self.spinner is not None:
            return not self.spinner.alive
        return not self.node.running

    def finish(self) -> None:
        """Stop its work, ``close()`` and ``destroy_node()`` (both always run); once."""
        if self.finished:
            return
        self.finished = True
        try:
            self.healthy = self._stop()
        finally:
            try:
                self.node.close()
            except Exception as err:  # noqa: BLE001 - reported; the other nodes still close
                self.healthy = False
                problem = f"{type(err).__name__}: {err}"
                print(f"{NAME}: {self.name}: close failed: {problem}", file=sys.stderr)
            finally:
                self.node.destroy_node()
        if self.name == "recorder" and self.node.write_error is not None:
            self.healthy = False  # the last chunk or the summary could not be written
        print(f"{NAME}: {self.name} stopped{'' if self.healthy else ' (failed)'}", flush=True)

    def _stop(self) -> bool:
        if self.spinner is not None:
            return self.spinner.stop()
        if self.name == "recorder":
            return bool(self.node.finish_recording())
        return bool(self.node.loop_error is None)  # a loop node: healthy unless its loop failed


def _build(name: str, cli_args: Sequence[str]) -> Member:
    """Build one node with its own ROS arguments (imports only the nodes asked for)."""
    if name == "pressure_source":
        from brake_hil.nodes.pressure_source import PressureSourceNode

        source = PressureSourceNode(cli_args, own_process=False)
        spinner = common.BackgroundSpinner(source, source.exit_requested, "source-executor")
        return Member(name, source, spinner)
    if name == "caliper_model":
        from brake_hil.nodes.caliper_model import CaliperModelNode

        return Member(name, CaliperModelNode(cli_args, own_process=False), None)
    if name == "comparator":
        from brake_hil.nodes.comparator import ComparatorNode

        return Member(name, ComparatorNode(cli_args), None)
    from brake_hil.nodes.recorder import RecorderNode

    return Member(name, RecorderNode(cli_args), None)


def pair_source_and_model(members: Sequence[Member]) -> None:
    """Step a ``paired_with_source`` caliper model on the replaying source's thread.

    Raises:
        BrakeHilError: the model asks for it and no replaying source is in the container.
    """
    by_name = {member.name: member.node for member in members}
    model = by_name.get("caliper_model")
    if model is None or not model.settings.paired_with_source:
        return
    source = by_name.get("pressure_source")
    if source is None:
        raise BrakeHilError("paired_with_source needs the pressure_source in this container")
    source.pair(model.follow, model.unpair)


def _ros_argument_errors() -> tuple[type[BaseException], ...]:
    """What rclpy raises on ROS arguments rcl cannot parse (unknown flags, a bad params file)."""
    from rclpy.impl.implementation_singleton import rclpy_implementation as implementation

    return (implementation.UnknownROSArgsError, implementation.RCLError)


def _bad_input() -> tuple[type[BaseException], ...]:
    """What a node raises when its parameters (or ROS arguments) are bad."""
    # OSError, ValueError: the recorder's bag exists or its folder is not writable.
    return (BrakeHilError, ParameterException, OSError, ValueError, *_ros_argument_errors())


def _problem(err: BaseException) -> str:
    """One line for a bad parameter or argument."""
    if type(err).__name__ == "UnknownROSArgsError":
        return f"unknown ROS arguments {err}"
    return " ".join(str(err).split()) or type(err).__name__


def name_threads() -> None:
    """Give the nodes' Python threads kernel names (``top -H``, per-thread CPU in /proc)."""
    for thread in threading.enumerate():
        native = thread.native_id
        if native is None or thread is threading.main_thread():
            continue
        name = THREAD_NAMES.get(thread.name, thread.name)[:15]
        try:
            Path(f"/proc/self/task/{native}/comm").write_text(name, encoding="utf-8")
        except OSError:
            pass  # not Linux, or the thread has ended


def wait_until_recorded(
    recorder: Any,
    hurry: threading.Event,
    quiet_s: float = RECORDER_QUIET_S,
    timeout_s: float = RECORDER_CATCH_UP_S,
) -> bool:
    """Wait until ``recorder`` has recorded nothing new for ``quiet_s``; True if so.

    At most ``timeout_s``, or until ``hurry`` is set.
    """
    deadline = time.monotonic() + timeout_s
    count, since = recorder.message_count, time.monotonic()
    while (now := time.monotonic()) < deadline and not hurry.is_set():
        if now - since >= quiet_s:
            return True
        hurry.wait(0.1)
        if (current := recorder.message_count) != count:
            count, since = current, time.monotonic()
    return False


# --------------------------------------------------------------------------- the process


def run(specs: Sequence[NodeSpec], stop: threading.Event, hurry: threading.Event) -> int:
    """Build the nodes, run them until ``stop`` (or until each has ended), stop them in order.

    rclpy must be initialised; it is shut down here. Returns the exit status.
    """
    members: list[Member] = []
    refused = False
    try:
        bad_input = _bad_input()
        for spec in specs:
            try:
                members.append(_build(spec.name, spec.ros_args))
            except bad_input as err:
                print(f"{NAME}: error: {spec.name}: {_problem(err)}", file=sys.stderr)
                refused = True
                hurry.set()  # close the nodes built so far, without waiting
                break
        if not refused:
            try:
                pair_source_and_model(members)
            except BrakeHilError as err:
                print(f"{NAME}: error: caliper_model: {_problem(err)}", file=sys.stderr)
                refused = True
                hurry.set()
        if not refused:
            name_threads()
            print(f"{NAME}: running {', '.join(m.name for m in members)}", flush=True)
        while not refused and not stop.wait(0.1):
            for member in members:
                if not member.finished and member.ended_by_itself():
                    member.finish()
            if all(member.finished for member in members):
                break
    finally:
        by_name = {member.name: member for member in members}
        for name in NODE_NAMES:
            left = by_name.get(name)
            if left is None or left.finished:
                continue
            if name == "recorder" and not hurry.is_set():
                wait_until_recorded(left.node, hurry)
            left.finish()
        rclpy.shutdown()
    if refused:
        return 2
    return 0 if all(member.healthy for member in members) else 1


def main(args: Sequence[str] | None = None) -> int:
    """``python -m brake_hil.nodes.container``; returns the exit status."""
    argv = list(sys.argv[1:] if args is None else args)
    if common.asks_for_help(argv[: argv.index("--node")] if "--node" in argv else argv):
        print(USAGE)
        return 0
    try:
        global_args, specs = parse_command_line(argv)
    except UsageError as err:
        print(f"{NAME}: error: {err}", file=sys.stderr)
        return 2
    problem = security_problem()
    if problem is not None:
        print(f"{NAME}: error: {problem}", file=sys.stderr)
        return 2
    stop, hurry = threading.Event(), threading.Event()

    def on_signal(signum: int, frame: object) -> None:
        del signum, frame
        if stop.is_set():
            hurry.set()  # a second signal: stop without waiting for the recorder to catch up
        stop.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, on_signal)
    os.environ.setdefault("RCUTILS_LOGGING_USE_STDOUT", "1")
    try:
        common.init_ros([f"brake_hil.nodes.{NAME}", *global_args])
    except _ros_argument_errors() as err:
        print(f"{NAME}: error: ROS arguments before --node: {_problem(err)}", file=sys.stderr)
        return 2
    return run(specs, stop, hurry)


if __name__ == "__main__":
    sys.exit(main())
