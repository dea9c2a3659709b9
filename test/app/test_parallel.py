"""The one parallel map: outcomes in the items' order whatever order they finish in, a failing
item reported on its own, the same results in this process as on a Dask LocalCluster, the
workers computing with one BLAS thread."""

from __future__ import annotations

import os

import pytest

from brake_hil.app.parallel import (
    SERIAL,
    Outcome,
    Workers,
    limit_blas_threads,
    openblas_threads,
    parallel_map,
    values,
    worker_count,
)
from brake_hil.errors import BrakeHilError

LOCAL_CLUSTER = Workers(jobs=2)


def square_or_refuse(value: int) -> int:
    """``value**2``; refuses 3 (module level, so Dask's workers import it by name)."""
    if value == 3:
        raise BrakeHilError(f"item {value}: refused")
    return value * value


def blas_threads_on_worker(_item: int) -> dict[str, int]:
    """The threads of each OpenBLAS loaded where this runs (numpy's and scipy's)."""
    import numpy  # noqa: F401
    import scipy.linalg  # noqa: F401

    return openblas_threads()


def process_id(_item: int) -> int:
    return os.getpid()


@pytest.mark.parametrize("workers", [SERIAL, LOCAL_CLUSTER], ids=["serial", "local_cluster"])
def test_outcomes_come_in_order_and_a_failure_stays_with_its_item(workers: Workers) -> None:
    seen: list[Outcome[int]] = []
    outcomes = parallel_map(square_or_refuse, range(8), workers, seen.append)
    assert [o.index for o in outcomes] == list(range(8))
    assert sorted(seen, key=lambda o: o.index) == outcomes  # each once, as it finished
    if workers.serial:
        assert seen == outcomes  # in this process: in the items' order
    assert [o.value for o in outcomes if o.ok] == [0, 1, 4, 16, 25, 36, 49]
    failed = [o for o in outcomes if not o.ok]
    assert [o.index for o in failed] == [3]
    assert isinstance(failed[0].error, BrakeHilError) and "item 3" in str(failed[0].error)
    with pytest.raises(BrakeHilError, match="item 3"):
        values(outcomes)


def test_this_process_and_a_local_cluster_give_the_same_results() -> None:
    items = [5, 1, 4, 2, 6, 0]
    serial = parallel_map(square_or_refuse, items, SERIAL)
    pooled = parallel_map(square_or_refuse, items, LOCAL_CLUSTER)
    assert values(serial) == values(pooled) == [25, 1, 16, 4, 36, 0]
    assert [(o.index, o.value, o.error) for o in serial] == [
        (o.index, o.value, o.error) for o in pooled
    ]


@pytest.mark.skipif(not openblas_threads(), reason="no OpenBLAS found loaded (Linux wheels)")
def test_local_cluster_workers_compute_with_one_blas_thread() -> None:
    threads = values(parallel_map(blas_threads_on_worker, [0, 1, 2, 3], LOCAL_CLUSTER))
    assert all(found and set(found.values()) == {1} for found in threads), threads


@pytest.mark.skipif(not openblas_threads(), reason="no OpenBLAS found loaded (Linux wheels)")
def test_an_openblas_loaded_before_is_told_the_thread_count(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    assert len(openblas_threads()) >= 1  # numpy's (and scipy's once imported)
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
    limit_blas_threads()
    assert set(openblas_threads().values()) == {2}
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "1")
    limit_blas_threads()
    assert set(openblas_threads().values()) == {1}


def test_worker_count() -> None:
    assert worker_count(4, 2) == 2
    assert worker_count(0, 5) == worker_count(1, 5) == 1
    assert worker_count(None, 10**6) == (os.cpu_count() or 1)
    assert worker_count(3, 0) == 1


def test_no_item_or_one_runs_in_this_process_without_a_scheduler() -> None:
    assert parallel_map(square_or_refuse, [], LOCAL_CLUSTER) == []
    assert values(parallel_map(process_id, [0], LOCAL_CLUSTER)) == [os.getpid()]


def test_workers_refuse_no_worker_process_and_serial_with_a_scheduler() -> None:
    with pytest.raises(BrakeHilError, match="--jobs 0"):
        Workers(jobs=0)
    with pytest.raises(BrakeHilError, match="choose one"):
        Workers(serial=True, scheduler="tcp://127.0.0.1:8786")
    assert Workers(jobs=2, scheduler="tcp://127.0.0.1:8786").scheduler  # the scheduler wins
