"""The one parallel map of the commands that work over many recordings.

``regress`` (replays), ``cases`` (virtual-rig simulations) and ``benchmark`` (blind
diagnoses) map one function over their items with :func:`parallel_map`; no other module of
brake_hil makes a process pool. Results come back in the items' order, and an item that
raises is reported as its own :class:`Outcome` while the others run to the end.

Each worker process computes with one BLAS thread: ``brake_hil/__init__.py`` sets
``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS`` and ``MKL_NUM_THREADS`` to 1 (unless the user
set them) before numpy loads, and the workers inherit that environment, so ``jobs`` processes
use ``jobs`` cores rather than ``jobs`` times the BLAS's threads.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
import os
from typing import Generic, TypeVar, cast

__all__ = ["Outcome", "parallel_map", "values", "worker_count"]

T = TypeVar("T")
R = TypeVar("R")


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
    jobs: int | None = 1,
    progress: Callable[[Outcome[R]], None] | None = None,
) -> list[Outcome[R]]:
    """``function`` of every item, over ``jobs`` worker processes, in the items' order.

    With one worker (``jobs`` 1 or one item) the items run in this process, one after the
    other; otherwise in a process pool, so ``function`` and the items must pickle (a
    module-level function or a :func:`functools.partial` of one).

    Args:
        function: called once per item.
        items: the inputs.
        jobs: worker processes (``None``: one per CPU; see :func:`worker_count`).
        progress: called with each item's outcome as soon as it and every item before it
            have finished (in the items' order).

    Returns:
        One :class:`Outcome` per item, in the items' order: its value, or the exception it
        raised (an ``Exception``; the other items still run to the end).
    """
    outcomes: list[Outcome[R]] = []

    def report(outcome: Outcome[R]) -> None:
        outcomes.append(outcome)
        if progress is not None:
            progress(outcome)

    workers = worker_count(jobs, len(items))
    if workers == 1:
        for index, item in enumerate(items):
            try:
                report(Outcome(index, value=function(item)))
            except Exception as err:  # reported per item: the rest still run
                report(Outcome(index, error=err))
        return outcomes
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(function, item) for item in items]
        for index, future in enumerate(futures):
            try:
                report(Outcome(index, value=future.result()))
            except Exception as err:  # raised in the worker, or the pool broke
                report(Outcome(index, error=err))
    return outcomes


def values(outcomes: Sequence[Outcome[R]]) -> list[R]:
    """Every outcome's value, in order.

    Raises:
        Exception: the first failed item's exception (in the items' order).
    """
    return [outcome.unwrap() for outcome in outcomes]
