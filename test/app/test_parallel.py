"""The one parallel map: results in order, a failing item reported on its own, the same
results in one process as in a pool, the workers computing with one BLAS thread."""

from __future__ import annotations

import os

import pytest

from brake_hil.app.parallel import Outcome, parallel_map, values, worker_count
from brake_hil.errors import BrakeHilError


def square_or_refuse(value: int) -> int:
    """``value**2``; refuses 3 (module level, so it pickles into a pool)."""
    if value == 3:
        raise BrakeHilError(f"item {value}: refused")
    return value * value


def blas_threads(_item: int) -> str | None:
    return os.environ.get("OPENBLAS_NUM_THREADS")


@pytest.mark.parametrize("jobs", [1, 2])
def test_results_come_in_order_and_a_failure_stays_with_its_item(jobs: int) -> None:
    seen: list[Outcome[int]] = []
    outcomes = parallel_map(square_or_refuse, range(8), jobs, seen.append)
    assert [o.index for o in outcomes] == list(range(8))
    assert seen == outcomes  # progress in the items' order
    assert [o.value for o in outcomes if o.ok] == [0, 1, 4, 16, 25, 36, 49]
    failed = [o for o in outcomes if not o.ok]
    assert [o.index for o in failed] == [3]
    assert isinstance(failed[0].error, BrakeHilError) and "item 3" in str(failed[0].error)
    with pytest.raises(BrakeHilError, match="item 3"):
        values(outcomes)


def test_one_process_and_a_pool_give_the_same_results() -> None:
    items = [5, 1, 4, 2, 6, 0]
    serial = parallel_map(square_or_refuse, items, jobs=1)
    pooled = parallel_map(square_or_refuse, items, jobs=2)
    assert values(serial) == values(pooled) == [25, 1, 16, 4, 36, 0]
    assert [(o.index, o.value, o.error) for o in serial] == [
        (o.index, o.value, o.error) for o in pooled
    ]


def test_workers_inherit_the_one_blas_thread_setting() -> None:
    assert os.environ["OPENBLAS_NUM_THREADS"]  # set by brake_hil/__init__.py (or the user)
    threads = values(parallel_map(blas_threads, [0, 1], jobs=2))
    assert threads == [os.environ["OPENBLAS_NUM_THREADS"]] * 2


def test_worker_count() -> None:
    assert worker_count(4, 2) == 2
    assert worker_count(0, 5) == worker_count(1, 5) == 1
    assert worker_count(None, 10**6) == (os.cpu_count() or 1)
    assert worker_count(3, 0) == 1
    assert parallel_map(square_or_refuse, [], jobs=2) == []
