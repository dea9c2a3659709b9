"""The container's ROS side: its nodes built, watched and stopped in one rclpy context.

What the container does and its command line: :mod:`brake_hil.nodes.container`, the entry
point, which answers ``--help`` and checks the command line without importing this.
"""

from __future__ import annotations

from collections.abc import Sequence
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
from brake_hil.nodes.container import (
    NAME,
    NODE_NAMES,
    RECORDER_CATCH_UP_S,
    RECORDER_QUIET_S,
    THREAD_NAMES,
    NodeSpec,
)

SWITCH_INTERVAL_S = 0.0002
"""Python's GIL switch interval in the container (s; Python's default 0.005): a thread that
wants the GIL (the source's 1 kHz loop) waits at most this long for another thread that holds
it in Python code (the recorder's or the comparator's batch). ``BRAKE_HIL_SWITCH_INTERVAL_S``
overrides it."""

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
        from brake_hil.nodes.pressure_source_node import PressureSourceNode

        source = PressureSourceNode(cli_args, own_process=False)
        spinner = common.BackgroundSpinner(source, source.exit_requested, "source-executor")
        return Member(name, source, spinner)
    if name == "caliper_model":
        from brake_hil.nodes.caliper_model_node import CaliperModelNode

        return Member(name, CaliperModelNode(cli_args, own_process=False), None)
    if name == "comparator":
        from brake_hil.nodes.comparator_node import ComparatorNode

        return Member(name, ComparatorNode(cli_args), None)
    from brake_hil.nodes.recorder_node import RecorderNode

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


def launch(global_args: Sequence[str], specs: Sequence[NodeSpec]) -> int:
    """Start rclpy with ``global_args``, run the nodes of ``specs``; the exit status.

    SIGINT or SIGTERM stops the nodes in the launcher's order; a second one stops them
    without waiting for the recorder to catch up.
    """
    stop, hurry = threading.Event(), threading.Event()

    def on_signal(signum: int, frame: object) -> None:
        del signum, frame
        if stop.is_set():
            hurry.set()  # a second signal: stop without waiting for the recorder to catch up
        stop.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, on_signal)
    sys.setswitchinterval(float(os.environ.get("BRAKE_HIL_SWITCH_INTERVAL_S", SWITCH_INTERVAL_S)))
    os.environ.setdefault("RCUTILS_LOGGING_USE_STDOUT", "1")
    try:
        common.init_ros([f"brake_hil.nodes.{NAME}", *global_args])
    except _ros_argument_errors() as err:
        print(f"{NAME}: error: ROS arguments before --node: {_problem(err)}", file=sys.stderr)
        return 2
    return run(specs, stop, hurry)
