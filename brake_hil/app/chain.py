"""The node chain as separate processes: source -> caliper model -> comparator -> recorder.

What ``ros2 launch`` would do, without a ROS install: each node is started as
``python -m brake_hil.nodes.<name> --ros-args --params-file <file>`` with
DDS local-only on loopback (:func:`.chain_environment.ros_environment`) and one
``ROS_DOMAIN_ID`` for the run, in its own
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
another), ``paired`` (as ``two-process``, with the model stepped on the source's thread right
after each sample: one thread for the two 1 kHz loops) or ``one-paired`` (the default,
:data:`DEFAULT_LAYOUT`: the four in one process, the model stepped on the source's thread, one
subscription per topic for the model, the comparator and the recorder). Each node
gets the same parameters from its own params file, started with the same environment; with a
container the launcher waits for the source's statistics file (written as its replay ends)
instead of the source's exit, and stops the container with SIGINT, which stops its nodes in the
same order (the recorder once it has caught up). Exit codes and CPU time are then the
container's (``ChainResult.exit_codes["container"]``). CPU and loop timing of each layout: the
README (``benchmarks/bench_cpu.py``, ``benchmarks/bench_soak.py``).

This module imports no rclpy: the nodes run in their own processes. The recorder is
optional: without ``brake_hil/nodes/recorder.py`` the chain runs without it and says so.
Node logs go to ``DIR/logs/``.

The parts, each its own module: the node processes (``chain_processes``), the environment and
its checks (``chain_environment``), the layouts (``chain_layouts``), the runs
(``chain_runs``) and their result (``chain_result``); this module gathers their names.
"""

from __future__ import annotations

from brake_hil.app.chain_environment import (
    DEFAULT_MODEL,
    DEFAULT_RECORDING,
    PROJECT,
    check_security,
    choose_domain_id,
    node_available,
    ros_environment,
)
from brake_hil.app.chain_layouts import (
    CONTAINER_STOP_S,
    DEFAULT_LAYOUT,
    LAYOUT_PARAMETERS,
    LAYOUTS,
    NODE_ORDER,
    start_layout,
)
from brake_hil.app.chain_processes import (
    CONTAINER,
    RECORDER_CATCH_UP_S,
    RECORDER_QUIET_S,
    NodeProcess,
    bag_bytes,
    start_container,
    start_node,
    stop_node,
    thread_cpu_seconds,
    wait_until_quiet,
)
from brake_hil.app.chain_result import ChainResult, check_recorded_predictions
from brake_hil.app.chain_runs import SOURCE_MARGIN_S, Notice, run_can_chain, run_chain

__all__ = [
    "CONTAINER",
    "CONTAINER_STOP_S",
    "DEFAULT_LAYOUT",
    "DEFAULT_MODEL",
    "DEFAULT_RECORDING",
    "LAYOUTS",
    "LAYOUT_PARAMETERS",
    "NODE_ORDER",
    "PROJECT",
    "RECORDER_CATCH_UP_S",
    "RECORDER_QUIET_S",
    "SOURCE_MARGIN_S",
    "ChainResult",
    "NodeProcess",
    "Notice",
    "bag_bytes",
    "check_recorded_predictions",
    "check_security",
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
