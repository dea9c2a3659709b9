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
import importlib
from pathlib import Path
import sys

from brake_hil.nodes.entry import asks_for_help
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


def main(args: Sequence[str] | None = None) -> int:
    """``python -m brake_hil.nodes.container``; returns the exit status.

    The help, the command line and the DDS security are checked before rclpy is imported.
    """
    argv = list(sys.argv[1:] if args is None else args)
    if asks_for_help(argv[: argv.index("--node")] if "--node" in argv else argv):
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
    ros_side = importlib.import_module("brake_hil.nodes.container_node")  # imports rclpy
    return int(ros_side.launch(global_args, specs))


if __name__ == "__main__":
    sys.exit(main())
