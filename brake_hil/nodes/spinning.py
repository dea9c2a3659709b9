"""How a node process runs: rclpy started and shut down, callbacks spun, signals waited for.

* :func:`init_ros` starts rclpy with rclpy's own signal handler off, ours on.
* :func:`spin_until_signal` (callbacks on a background executor, rclpy's EventsExecutor when
  available: :class:`BackgroundSpinner`) or :func:`wait_for_signal` (a node whose own thread
  does the work) run until SIGINT/SIGTERM, so a node can finish its work (drain, final
  diagnostics, files, ``wait_for_acks``) before ``destroy_node()`` / ``rclpy.shutdown()``.
* :func:`run_node`: the life of a node process; :class:`LoopNode` and
  :func:`run_until_stopped` for a node whose work runs on a loop thread of its own.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
import contextlib
import os
import signal
import sys
import threading
from typing import Any, TypeVar

import rclpy
from rclpy.context import Context
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from brake_hil.nodes.entry import setup_environment
from brake_hil.runtime import security_problem

__all__ = [
    "BackgroundSpinner",
    "LoopNode",
    "init_ros",
    "make_executor",
    "run_node",
    "run_until_stopped",
    "spin_until_signal",
    "wait_for_signal",
]


def init_ros(args: Sequence[str] | None) -> None:
    """``rclpy.init`` without rclpy's signal handlers (see :func:`spin_until_signal`)."""
    setup_environment()
    rclpy.init(
        args=list(args) if args is not None else None,
        signal_handler_options=SignalHandlerOptions.NO,
    )


def make_executor(context: Context | None = None) -> Executor:
    """The EventsExecutor of rclpy, or the SingleThreadedExecutor when asked or missing.

    The EventsExecutor dispatches callbacks from C++: about half the cost a message of the
    default executor, which matters at several kHz on 2 cores. ``BRAKE_HIL_EXECUTOR=single``
    or an rclpy without it gives the SingleThreadedExecutor.
    """
    if os.environ.get("BRAKE_HIL_EXECUTOR", "events") != "single":
        try:
            from rclpy.experimental import EventsExecutor
        except ImportError:  # rclpy before Jazzy
            pass
        else:
            return EventsExecutor(context=context)
    return SingleThreadedExecutor(context=context)


class BackgroundSpinner:
    """A node's callbacks run by an executor of its own on a background thread.

    Spins until ``stop`` is set (:meth:`stop`), or until a callback raises (the executor stops
    at the first exception, which is printed; :attr:`healthy` turns False). The node outlives
    the executor, so it can finish its work (drain, final diagnostics) before
    ``destroy_node()``. :func:`spin_until_signal` runs one until a signal; the container
    (:mod:`brake_hil.nodes.container`) runs one per node that has callbacks.
    """

    def __init__(
        self, node: Node, stop: threading.Event | None = None, name: str = "executor"
    ) -> None:
        self.stop_event = stop if stop is not None else threading.Event()
        self._failed = threading.Event()
        self._executor = make_executor()
        self._executor.add_node(node)
        self._thread = threading.Thread(
            target=_spin,
            args=(self._executor, self.stop_event, self._failed),
            name=name,
            daemon=True,
        )
        self._thread.start()

    @property
    def alive(self) -> bool:
        """True while the executor spins."""
        return self._thread.is_alive()

    @property
    def healthy(self) -> bool:
        """False once a callback raised."""
        return not self._failed.is_set()

    @property
    def native_id(self) -> int | None:
        """The spinning thread's kernel id (``/proc/self/task/<id>``)."""
        return self._thread.native_id

    def stop(self, timeout_s: float = 2.0) -> bool:
        """Stop spinning and shut the executor down; returns :attr:`healthy`."""
        self.stop_event.set()
        self._thread.join(timeout_s)
        if not self._thread.is_alive():
            self._executor.shutdown()
        return self.healthy


def spin_until_signal(node: Node, stop: threading.Event | None = None) -> bool:
    """Run ``node``'s callbacks on a background executor until SIGINT or SIGTERM.

    Also until ``stop`` is set, or the context shuts down; then stop the executor
    (:class:`BackgroundSpinner`).

    Returns False when a callback raised (the executor stops at the first exception, which is
    logged), True otherwise: ``main`` turns False into exit status 1.
    """
    stop = stop if stop is not None else threading.Event()
    with _stopped_by_signals(stop):
        spinner = BackgroundSpinner(node, stop)
        try:
            while not stop.wait(0.1) and node.context.ok() and spinner.alive:
                pass
        finally:
            spinner.stop()
    return spinner.healthy


def wait_for_signal(finished: Callable[[], bool] = lambda: False) -> None:
    """Block until SIGINT or SIGTERM, or until ``finished()`` (polled every 0.1 s).

    For a node whose own thread does all its work, with no executor to spin.
    """
    stop = threading.Event()
    with _stopped_by_signals(stop):
        while not stop.wait(0.1) and not finished():
            pass


@contextlib.contextmanager
def _stopped_by_signals(stop: threading.Event) -> Iterator[None]:
    """SIGINT and SIGTERM set ``stop`` inside the block; the previous handlers after it."""

    def on_signal(signum: int, frame: object) -> None:
        del signum, frame
        stop.set()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _spin(executor: Executor, stop: threading.Event, failed: threading.Event) -> None:
    # spin_once in a loop rather than spin(): the EventsExecutor's shutdown() from another
    # thread does not return while spin() runs, and the node must outlive the executor to
    # finish its work (drain, final diagnostics) before rclpy.shutdown().
    try:
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)
    except Exception as err:  # noqa: BLE001 - the main thread ends the node
        print(f"executor stopped: {type(err).__name__}: {err}", file=sys.stderr)
        failed.set()
    finally:
        stop.set()


NodeT = TypeVar("NodeT", bound=Node)


def run_node(
    name: str,
    args: Sequence[str] | None,
    make_node: Callable[[], NodeT],
    bad_input: tuple[type[BaseException], ...],
    run: Callable[[NodeT], bool],
) -> int:
    """The life of a node process: init (loopback discovery), build, run, close, shut down.

    A node that cannot be built from its parameters (``bad_input``) exits 2 with one line;
    ``run`` returns whether the node stayed healthy (exit 0, else 1). ``close()`` and
    ``destroy_node()`` always run, so a recording is finalised even after an error.
    (A node's entry module answers ``-h``/``--help`` before it imports this:
    :func:`brake_hil.nodes.entry.answer_help`.) DDS security asked for where the DDS has no
    security plugins is one line and exit 2 (:func:`brake_hil.runtime.security_problem`),
    before rclpy starts.
    """
    problem = security_problem()
    if problem is not None:
        print(f"{name}: error: {problem}", file=sys.stderr)
        return 2
    init_ros(args)
    try:
        node = make_node()
    except bad_input as err:
        print(f"{name}: error: {err}", file=sys.stderr)
        rclpy.shutdown()
        return 2
    try:
        healthy = run(node)
    finally:
        node.close()  # type: ignore[attr-defined]
        node.destroy_node()
        rclpy.shutdown()
    return 0 if healthy else 1


class LoopNode(Node):
    """A node whose work runs on a loop thread of its own.

    The loop is ``self._loop``, with ``running`` and ``error``: what
    :func:`run_until_stopped` waits on and reports.
    """

    _loop: Any
    loop_name = "loop"

    @property
    def running(self) -> bool:
        """True while the node's loop runs."""
        return bool(self._loop.running)

    @property
    def loop_error(self) -> BaseException | None:
        """What stopped the loop, None while it runs or after a clean stop."""
        error: BaseException | None = self._loop.error
        return error

    def _on_loop_error(self, error: BaseException) -> None:
        if self.context.ok():
            self.get_logger().fatal(f"{self.loop_name} stopped: {type(error).__name__}: {error}")


def run_until_stopped(node: Any) -> bool:
    """``run`` of :func:`run_node` for nodes that work on their own thread.

    Wait for a signal or the node's end; healthy unless its loop failed.
    """
    wait_for_signal(lambda: not node.running)
    return node.loop_error is None
