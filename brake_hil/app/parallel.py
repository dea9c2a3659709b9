"""The one parallel map of the commands that work over many recordings, on Dask.

``regress`` (replays), ``cases`` (virtual-rig simulations) and ``benchmark`` (blind
diagnoses) map one function over their items with :func:`parallel_map`; no other module of
brake_hil starts worker processes. :class:`Workers` says where the map runs: in this process
(``serial``), on a Dask ``LocalCluster`` it starts on loopback for the map (``jobs`` worker
processes), or on a running Dask scheduler (``scheduler``, e.g. one started with ``dask
scheduler`` and ``dask worker`` on other machines). Results come back in the items' order; an
item that raises (or whose worker dies, ``KilledWorker`` once Dask has retried it) is
reported as its own :class:`Outcome` while the others run to the end.

Each worker computes with one BLAS thread (every matrix here is tiny; ``brake_hil/__init__.py``
says why): Dask's nanny starts its workers with ``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``
and ``MKL_NUM_THREADS`` at 1, and every task first calls :func:`limit_blas_threads`, which also
holds for a worker started without a nanny (its numpy, and so its OpenBLAS, is loaded before
the first task, too late for the environment).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
import ctypes
from dataclasses import dataclass
from functools import partial
import logging
import os
from pathlib import Path
import socket
import sys
from typing import TYPE_CHECKING, Any, Generic, TypeVar, cast
import uuid

from brake_hil.errors import BrakeHilError

if TYPE_CHECKING:
    from distributed import Client

__all__ = [
    "BLAS_THREAD_VARIABLES",
    "LOCAL_CLUSTER_CONFIG",
    "LOOPBACK",
    "ONE_PER_CORE",
    "SCHEDULER_TIMEOUT_S",
    "SERIAL",
    "Outcome",
    "Workers",
    "limit_blas_threads",
    "openblas_threads",
    "parallel_map",
    "values",
    "worker_count",
    "write_dask_config",
]

T = TypeVar("T")
R = TypeVar("R")

LOOPBACK = "127.0.0.1"
"""Where an embedded ``LocalCluster`` listens: nothing on other interfaces."""
SCHEDULER_TIMEOUT_S = 10.0
"""Seconds a running scheduler has to answer, and then to have at least one worker."""
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
"""What ``brake_hil/__init__.py`` sets to 1 (unless the user set them) before numpy loads."""
_OPENBLAS_PREFIXES = ("openblas", "scipy_openblas")  # scipy_: numpy's and scipy's wheels
_OPENBLAS_SUFFIXES = ("", "64_")  # 64_: 64-bit integers (numpy's wheels)
LOCAL_CLUSTER_CONFIG: dict[str, object] = {
    # A worker holds only the task it runs, so a task that kills its worker takes no queued
    # neighbour down with it (KilledWorker stays with its item).
    "distributed.scheduler.worker-saturation": 1.0,
    # Dask's defaults cost a diagnosis 31 % in a worker against this process (measured,
    # 4 recordings, 1 worker: 47 s against 35 s): glibc told to give memory back at every
    # 64 KiB free (MALLOC_TRIM_THRESHOLD_, 11 % of it), the statistical profiler sampling the
    # task's stack every 10 ms, the event loop's 20 ms watchdog tick. Off here, 39-40 s.
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
}
"""Dask settings of the embedded ``LocalCluster``; a cluster of your own reads them from a
YAML file in its Dask config folder (:func:`write_dask_config`)."""
_DASK_LOG_LEVEL = "DASK_LOGGING__DISTRIBUTED"
"""Dask's log level in the worker processes a ``LocalCluster`` starts (read at their import)."""


@dataclass(frozen=True)
class Workers:
    """Where a map over recordings runs.

    Raises:
        BrakeHilError: ``jobs`` below 1, or ``serial`` with a ``scheduler``.
    """

    jobs: int | None = None  # worker processes of an embedded LocalCluster (None: one per core)
    scheduler: str | None = None  # a running Dask scheduler, tcp://127.0.0.1:8786 (wins over jobs)
    serial: bool = False  # in this process, one item after the other

    def __post_init__(self) -> None:
        if self.jobs is not None and self.jobs < 1:
            raise BrakeHilError(f"--jobs {self.jobs}: at least 1 worker process")
        if self.serial and self.scheduler is not None:
            raise BrakeHilError(f"--serial and --scheduler {self.scheduler}: choose one")


SERIAL = Workers(serial=True)
"""In this process, one item after the other."""
ONE_PER_CORE = Workers()
"""A ``LocalCluster`` of one worker process per core (at most one per item)."""


@dataclass(frozen=True)
class Outcome(Generic[R]):
    """What one item gave: its value, or the exception it raised."""

    index: int  # position of the item in the map's input
    value: R | None = None
    error: Exception | None = None

    @property
    def ok(self) -> bool:
        """True when the item returned a value."""
        return self.error is None

    def unwrap(self) -> R:
        """The item's value.

        Raises:
            Exception: the exception the item raised.
        """
        if self.error is not None:
            raise self.error
        return cast(R, self.value)


def worker_count(jobs: int | None, items: int) -> int:
    """Processes for ``items`` items: ``jobs`` (``None``: one per CPU), at most one per item.

    Args:
        jobs: requested worker processes; ``None`` for one per CPU, below 1 counts as 1.
        items: number of items to map.

    Returns:
        The number of workers, at least 1.
    """
    requested = (os.cpu_count() or 1) if jobs is None else jobs
    return max(1, min(requested, items))


def parallel_map(
    function: Callable[[T], R],
    items: Sequence[T],
    workers: Workers,
    progress: Callable[[Outcome[R]], None] | None = None,
) -> list[Outcome[R]]:
    """``function`` of every item, where ``workers`` says; the outcomes in the items' order.

    Serial (``workers.serial``, or at most one item and no scheduler), the items run in this
    process, one after the other. Otherwise each is a Dask task (``pure=False``: never taken
    from a cache) on a ``LocalCluster`` of :func:`worker_count` processes, one thread each,
    listening on 127.0.0.1 only and closed after the map, or on ``workers.scheduler``'s
    workers; ``function`` and the items must then pickle, and a function the workers import
    by name (a module-level function, or a :func:`functools.partial` of one) must be
    importable there. Dask's own log lines below CRITICAL are held back while the map runs.

    Args:
        function: called once per item.
        items: the inputs.
        workers: where the items run.
        progress: called with each item's outcome as it finishes (serial: in the items'
            order; on Dask: in the order they finish).

    Returns:
        One :class:`Outcome` per item, in the items' order: its value, or the exception it
        raised (an ``Exception``, ``distributed.KilledWorker`` when its workers died; the
        other items still run to the end).

    Raises:
        BrakeHilError: ``workers.scheduler`` does not answer, or has no worker, within
            :data:`SCHEDULER_TIMEOUT_S`.
    """
    outcomes: list[Outcome[R] | None] = [None] * len(items)

    def report(outcome: Outcome[R]) -> None:
        outcomes[outcome.index] = outcome
        if progress is not None:
            progress(outcome)

    if workers.scheduler is None and (workers.serial or len(items) <= 1):
        for index, item in enumerate(items):
            try:
                report(Outcome(index, value=function(item)))
            except Exception as err:  # reported per item: the rest still run
                report(Outcome(index, error=err))
        return cast(list[Outcome[R]], outcomes)
    from distributed import as_completed

    prefix = f"{_task_name(function)}-{uuid.uuid4().hex}"
    with _quiet_dask(), _dask_client(workers, len(items)) as client:
        futures = [
            client.submit(_on_one_blas_thread, function, item, key=f"{prefix}-{index}", pure=False)
            for index, item in enumerate(items)
        ]
        index_of = {future.key: index for index, future in enumerate(futures)}
        finished = as_completed(futures, loop=client.loop)  # type: ignore[no-untyped-call]
        del futures
        # Each task is released as soon as its result is here: a worker lost later cannot
        # make Dask compute it again.
        for future in finished:
            index = index_of[future.key]
            try:
                outcome = Outcome(index, value=future.result())
            except Exception as err:  # raised in the worker, or its workers died
                outcome = Outcome(index, error=err)
            future.release()
            report(outcome)
    return cast(list[Outcome[R]], outcomes)


def write_dask_config(folder: Path | str) -> Path:
    """Write :data:`LOCAL_CLUSTER_CONFIG` as ``folder/brake_hil.yaml``, Dask's config format.

    For a scheduler and workers started apart: put the file in their Dask config folder
    (``~/.config/dask/``, or the folder ``$DASK_CONFIG`` names) before starting them.
    """
    import yaml

    nested: dict[str, Any] = {}
    for dotted, value in LOCAL_CLUSTER_CONFIG.items():
        *parents, leaf = dotted.split(".")
        node = nested
        for parent in parents:
            node = node.setdefault(parent, {})
        node[leaf] = value
    path = Path(folder).expanduser() / "brake_hil.yaml"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(nested, sort_keys=True), encoding="utf-8")
    return path


def values(outcomes: Sequence[Outcome[R]]) -> list[R]:
    """Every outcome's value, in order.

    Raises:
        Exception: the first failed item's exception (in the items' order).
    """
    return [outcome.unwrap() for outcome in outcomes]


def limit_blas_threads() -> None:
    """Compute with ``OPENBLAS_NUM_THREADS`` BLAS threads in this process (1 unless set).

    Sets :data:`BLAS_THREAD_VARIABLES` (unless set) for the BLAS libraries loaded from now
    on, and tells each OpenBLAS loaded already (numpy's and scipy's wheels bring one each)
    through its own ``set_num_threads``: it read the environment when it loaded. Reads the
    loaded libraries from ``/proc/self/maps`` (Linux); elsewhere only the environment is set.
    """
    for variable in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(variable, "1")
    try:
        threads = max(1, int(os.environ["OPENBLAS_NUM_THREADS"]))
    except ValueError:
        threads = 1
    for setter in _openblas_functions("set_num_threads").values():
        setter(threads)


def openblas_threads() -> dict[str, int]:
    """The threads each OpenBLAS this process has loaded computes with, by library path.

    Empty when none is loaded, or off Linux (see :func:`limit_blas_threads`).
    """
    return {path: int(get()) for path, get in _openblas_functions("get_num_threads").items()}


def _openblas_functions(name: str) -> dict[str, Callable[..., int]]:
    """The function ``openblas_<name>`` of each OpenBLAS this process has loaded, by path."""
    found: dict[str, Callable[..., int]] = {}
    for path in _loaded_openblas():
        try:
            library = ctypes.CDLL(path)
        except OSError:
            continue
        for prefix in _OPENBLAS_PREFIXES:
            for suffix in _OPENBLAS_SUFFIXES:
                function = getattr(library, f"{prefix}_{name}{suffix}", None)
                if function is not None and path not in found:
                    found[path] = function
    return found


def _loaded_openblas() -> list[str]:
    """Paths of the OpenBLAS libraries this process has loaded (Linux; else none)."""
    if not sys.platform.startswith("linux"):
        return []
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as maps:
            paths = {line.split()[-1] for line in maps if "openblas" in line.lower()}
    except OSError:
        return []
    return sorted(path for path in paths if path.startswith("/") and ".so" in path)


def _task_name(function: Callable[..., object]) -> str:
    """The name of ``function`` (of the function under a :func:`functools.partial`)."""
    while isinstance(function, partial):
        function = function.func
    return str(getattr(function, "__name__", "item"))


def _on_one_blas_thread(function: Callable[[T], R], item: T) -> R:
    """``function(item)`` on a worker, after :func:`limit_blas_threads`."""
    limit_blas_threads()
    return function(item)


@contextmanager
def _quiet_dask() -> Iterator[None]:
    """Dask's log lines held back, here and in the workers it starts meanwhile.

    Only CRITICAL ones pass: what goes wrong with an item (even ``Compute Failed``, which
    Dask logs as an error) reaches the caller as that item's :class:`Outcome`.
    """
    from distributed.utils import silence_logging_cmgr

    previous = os.environ.get(_DASK_LOG_LEVEL)
    os.environ[_DASK_LOG_LEVEL] = "critical"
    try:
        with silence_logging_cmgr(logging.CRITICAL):
            yield
    finally:
        if previous is None:
            os.environ.pop(_DASK_LOG_LEVEL, None)
        else:
            os.environ[_DASK_LOG_LEVEL] = previous


@contextmanager
def _dask_client(workers: Workers, items: int) -> Iterator[Client]:
    """A client of ``workers.scheduler``, or of a ``LocalCluster`` on 127.0.0.1 for ``items``."""
    import dask
    from distributed import Client, LocalCluster

    if workers.scheduler is not None:
        address = workers.scheduler
        _check_reachable(address)
        try:
            client = Client(  # type: ignore[no-untyped-call]
                address, timeout=SCHEDULER_TIMEOUT_S, set_as_default=False
            )
        except (OSError, ValueError) as err:
            raise _unreachable(address, err) from err
        with client:
            try:
                client.wait_for_workers(1, timeout=SCHEDULER_TIMEOUT_S)
            except TimeoutError as err:
                msg = f"{address}: the Dask scheduler has no worker ({SCHEDULER_TIMEOUT_S:g} s)"
                raise BrakeHilError(msg) from err
            yield client
        return
    # LOCAL_CLUSTER_CONFIG: see there. The scheduler's HTTP server (health, metrics; served
    # without a dashboard too) takes a free port on loopback rather than 8787.
    with (
        dask.config.set(LOCAL_CLUSTER_CONFIG),
        LocalCluster(  # type: ignore[no-untyped-call]
            n_workers=worker_count(workers.jobs, items),
            threads_per_worker=1,
            processes=True,
            host=LOOPBACK,
            scheduler_port=0,
            dashboard_address=None,
            scheduler_kwargs={"dashboard_address": f"{LOOPBACK}:0"},
            silence_logs=logging.CRITICAL,
        ) as cluster,
        Client(cluster, set_as_default=False) as client,  # type: ignore[no-untyped-call]
    ):
        yield client


def _check_reachable(address: str) -> None:
    """Refuse a TCP scheduler address nothing answers on within :data:`SCHEDULER_TIMEOUT_S`.

    Checked with a plain socket before a ``Client`` is made: a ``Client`` that fails to
    connect leaves tracebacks on stderr when it is collected.
    """
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address)
        if scheme not in ("tcp", "tls"):
            return
        host, port = parse_host_port(location)
        with socket.create_connection((host, port), timeout=SCHEDULER_TIMEOUT_S):
            pass
    except (OSError, ValueError, TypeError) as err:
        raise _unreachable(address, err) from err


def _unreachable(address: str, cause: Exception) -> BrakeHilError:
    """The one-line refusal of a scheduler address, with what went wrong."""
    if isinstance(cause, TimeoutError) and not str(cause).startswith("Timed out"):
        reason = f"nothing answered within {SCHEDULER_TIMEOUT_S:g} s"
    else:
        reason = (str(cause).strip().splitlines() or [type(cause).__name__])[0]
    return BrakeHilError(f"{address}: no Dask scheduler reachable ({reason})")
