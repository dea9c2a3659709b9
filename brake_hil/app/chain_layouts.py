"""The chain's layouts: which nodes share a process, and starting a plan in one.

A layout names, per node, the container process it runs in (a node not named runs in its own
process): ``processes`` (each its own), ``one-process`` (the four in
``python -m brake_hil.nodes.container``), ``model-apart`` (the caliper model in its own, the
rest in one), ``two-process`` (the source and the model in one, the comparator and the
recorder in another), ``paired`` (as ``two-process``, the model stepped on the source's
thread right after each sample) and ``one-paired`` (the four in one process, the model stepped
on the source's thread). No rclpy.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from brake_hil.app.chain_processes import CONTAINER, NodeProcess, start_container, start_node

__all__ = [
    "CONTAINER_STOP_S",
    "DEFAULT_LAYOUT",
    "LAYOUTS",
    "LAYOUT_PARAMETERS",
    "NODE_ORDER",
    "SHARED_TAKES",
    "readers_per_topic",
    "start_layout",
]

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
    "one-paired": dict.fromkeys(NODE_ORDER, CONTAINER),
}
"""Which nodes share a process: node name -> the container's process name; a node not named
runs in its own process. ``two-process``: the source and the model (the 1 kHz loops) in one,
the comparator and the recorder in another; ``paired``: as ``two-process``, the model stepped
on the source's thread (:data:`LAYOUT_PARAMETERS`); ``one-paired``: the four in one process,
the model stepped on the source's thread."""
LAYOUT_PARAMETERS: dict[str, dict[str, dict[str, Any]]] = {
    "paired": {"caliper_model": {"paired_with_source": True}},
    "one-paired": {"caliper_model": {"paired_with_source": True}},
}
"""Node parameters a layout sets (over the plan's): layout -> node -> parameters."""
SHARED_TAKES = frozenset({"one-paired"})
"""Layouts whose container shares one subscription per topic among its nodes
(``BRAKE_HIL_SHARED_TAKES=1``, :class:`brake_hil.nodes.common.PolledSubscription`)."""
DEFAULT_LAYOUT = "one-paired"
"""The chain's layout when none is asked for."""
SHARED_TAKES_VARIABLE = "BRAKE_HIL_SHARED_TAKES"
"""What such a container gets in its environment (:mod:`brake_hil.nodes.common`'s name)."""
READERS = {
    "p_i": ("caliper_model", "recorder"),
    "measured": ("comparator", "recorder"),
    "predicted": ("comparator", "recorder"),
}
"""Which of the chain's nodes read each kind of sample topic."""


def readers_per_topic(layout: str, recorder: bool = True) -> dict[str, int]:
    """Subscriptions each kind of sample topic (``READERS``) gets in ``layout``.

    One per reading node; in a layout of :data:`SHARED_TAKES`, one per process: what the
    source and the model must wait for before they publish.
    """
    groups = LAYOUTS[layout]
    counts = {}
    for kind, nodes in READERS.items():
        present = [node for node in nodes if recorder or node != "recorder"]
        if layout in SHARED_TAKES:
            counts[kind] = len({groups.get(node, node) for node in present})
        else:
            counts[kind] = len(present)
    return counts


CONTAINER_STOP_S = 100.0
"""How long the launcher gives the container to stop after SIGINT (s): the source's and the
model's wait for acknowledgements (8 s each) and the recorder's catch-up (at most 60 s)."""


def start_layout(
    plan: Sequence[tuple[str, Mapping[str, Any]]],
    env: Mapping[str, str],
    workdir: Path,
    layout: str = "processes",
    fifo_priority: Mapping[str, int] | None = None,
    container_priority: int = 0,
) -> list[NodeProcess]:
    """Start the nodes of ``plan`` (name, parameters; readers first) as ``layout`` says.

    A process is started when its first node's turn in ``plan`` comes (a container with all
    its nodes, in plan order). ``fifo_priority``: per node name, a ``SCHED_FIFO`` priority for
    a node in its own process (:func:`start_node`); containers start normally (their loop
    threads raise themselves: the nodes' ``realtime_priority``; a whole container under
    ``SCHED_FIFO``, tried on a quiet machine, took more CPU, 60 against 47 % of a core, for no
    better timing), except in a layout of :data:`SHARED_TAKES` with ``container_priority`` > 0:
    its one process under ``SCHED_FIFO`` at that priority (the comparator, the recorder and
    the middleware's threads keep up on a busy machine; the loop thread raises itself above).
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
            shared = {SHARED_TAKES_VARIABLE: "1"} if layout in SHARED_TAKES else {}
            fifo = container_priority if layout in SHARED_TAKES else 0
            processes.append(
                start_container(members, {**env, **shared}, workdir, fifo, name=group)
            )
    return processes
