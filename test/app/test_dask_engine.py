"""The map on Dask: a LocalCluster and a scheduler with workers started apart give what one
process gives, on loopback only, with one BLAS thread per worker; a failing item and a killed
worker stay with their items; an unreachable scheduler is one line naming its address.

Counts and contracts only, with generous deadlines: these hold on a busy 2-core runner.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
import json
import os
from pathlib import Path
import signal
import socket
import subprocess
import sys
import time

from mcap.reader import make_reader
import psutil
import pytest

from brake_hil.app import parallel
from brake_hil.app.cases import CaseOptions, generate_cases
from brake_hil.app.parallel import SERIAL, Outcome, Workers, openblas_threads, parallel_map, values
from brake_hil.errors import BrakeHilError
from test.app.test_parallel import blas_threads_on_worker, square_or_refuse
from test.conftest import PROJECT

DASK = Path(sys.executable).with_name("dask")
BAG = PROJECT / "bags" / "one_washer_lti"
START_DEADLINE_S = 120.0  # a scheduler and its workers up, on a busy runner


def refuse_3_kill_4(value: int) -> int:
    """``value**2``; item 3 raises, item 4 kills its worker process (every time Dask retries)."""
    if value == 4:
        os._exit(1)
    return square_or_refuse(value)


def listening_on_a_worker(_item: int) -> tuple[str, list[str]]:
    """The scheduler's address and the addresses this worker process listens on."""
    from distributed import get_worker

    time.sleep(0.5)
    connections = psutil.Process().net_connections(kind="inet")
    listening = [c.laddr.ip for c in connections if c.status == psutil.CONN_LISTEN]
    return get_worker().scheduler.address, listening


def worker_and_blas_threads(_item: int) -> tuple[str, dict[str, int]]:
    """The worker this ran on and its BLAS threads (a moment's work, so both workers get some)."""
    from distributed import get_worker

    time.sleep(0.5)
    return get_worker().address, blas_threads_on_worker(_item)


def mcap_messages(recording: Path) -> list[tuple[str, int, bytes]]:
    """Every message of a recording's MCAP files: topic, log time (ns), payload."""
    found = []
    for path in sorted(recording.glob("*.mcap")):
        with path.open("rb") as stream:
            for _schema, channel, message in make_reader(stream).iter_messages():
                found.append((channel.topic, message.log_time, bytes(message.data)))
    return found


# --------------------------------------------------------------------------- LocalCluster


def test_cases_on_a_local_cluster_are_those_of_one_process(tmp_path: Path) -> None:
    made = {}
    for name, workers in (("serial", SERIAL), ("cluster", Workers(jobs=2))):
        labels = generate_cases(tmp_path / name, 2, 4, CaseOptions(pulsing_s=0.4), workers=workers)
        document = json.loads(labels.read_text())
        for label in document["cases"].values():
            label.pop("simulation_seconds")  # wall time
        made[name] = document
    assert made["serial"] == made["cluster"]
    for case in ("000", "001"):
        serial = mcap_messages(tmp_path / "serial" / "cases" / case / "recording")
        cluster = mcap_messages(tmp_path / "cluster" / "cases" / case / "recording")
        assert len(serial) > 1000 and serial == cluster
        rig = (tmp_path / "serial" / "cases" / case / "rig.yaml").read_text()
        assert rig == (tmp_path / "cluster" / "cases" / case / "rig.yaml").read_text()


def test_a_failing_item_and_a_killed_worker_stay_with_their_items(
    capfd: pytest.CaptureFixture[str],
) -> None:
    seen: list[Outcome[int]] = []
    outcomes = parallel_map(refuse_3_kill_4, range(7), Workers(jobs=2), seen.append)
    assert sorted(o.index for o in seen) == list(range(7))  # progress once per item
    assert {o.index: o.value for o in outcomes if o.ok} == {0: 0, 1: 1, 2: 4, 5: 25, 6: 36}
    errors = {o.index: o.error for o in outcomes if not o.ok}
    assert isinstance(errors[3], BrakeHilError) and "item 3" in str(errors[3])
    assert type(errors[4]).__name__ == "KilledWorker"
    assert "distributed." not in capfd.readouterr().err  # Dask's log lines held back


def test_a_local_cluster_listens_on_loopback_only() -> None:
    found = values(parallel_map(listening_on_a_worker, range(4), Workers(jobs=2)))
    assert all(scheduler.startswith("tcp://127.0.0.1:") for scheduler, _ in found)
    assert all(listening for _, listening in found)  # the worker's own port, its HTTP server
    assert {ip for _, listening in found for ip in listening} == {"127.0.0.1"}


# --------------------------------------------------------------------------- started apart


@dataclass(frozen=True)
class Apart:
    """A Dask scheduler and two worker processes started as their own processes."""

    address: str
    processes: tuple[subprocess.Popen[bytes], ...]


def _start(
    arguments: list[str], environment: dict[str, str], log: Path
) -> subprocess.Popen[bytes]:
    with log.open("wb") as output:
        return subprocess.Popen(
            [str(DASK), *arguments],
            cwd=PROJECT,
            env=environment,
            stdout=output,
            stderr=subprocess.STDOUT,
            start_new_session=True,  # its own process group: the finalizer kills all of it
        )


def _stop(processes: list[subprocess.Popen[bytes]]) -> None:
    for process in processes:
        try:
            os.killpg(process.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        process.wait(timeout=30)


def _wait_for(condition: object, what: str, processes: list[subprocess.Popen[bytes]]) -> None:
    deadline = time.monotonic() + START_DEADLINE_S
    while not condition():  # type: ignore[operator]
        if any(p.poll() is not None for p in processes):
            raise RuntimeError(f"a Dask process ended while waiting for {what}")
        if time.monotonic() > deadline:
            raise TimeoutError(f"no {what} within {START_DEADLINE_S} s")
        time.sleep(0.2)


@pytest.fixture(scope="module")
def apart(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Apart]:
    """``dask scheduler`` and two ``dask worker``s on 127.0.0.1, without BLAS settings.

    One worker under a nanny (which sets one BLAS thread itself), one without (only the
    map's own :func:`~brake_hil.app.parallel.limit_blas_threads` does).
    """
    from distributed import Client

    folder = tmp_path_factory.mktemp("dask")
    scheduler_file = folder / "scheduler.json"
    environment = {
        key: value
        for key, value in os.environ.items()
        if key not in parallel.BLAS_THREAD_VARIABLES
    }
    environment["PYTHONPATH"] = str(PROJECT)  # the workers import this test module by name
    # --no-dashboard still serves HTTP (health, metrics), on all interfaces unless told
    common = ["--host", "127.0.0.1", "--no-dashboard", "--dashboard-address", "127.0.0.1:0"]
    common += ["--scheduler-file", str(scheduler_file)]
    processes: list[subprocess.Popen[bytes]] = []
    try:
        processes.append(_start(["scheduler", "--port", "0", *common], environment, folder / "s"))
        _wait_for(scheduler_file.is_file, "scheduler file", processes)
        worker = ["worker", "--nthreads", "1", "--local-directory", str(folder), *common]
        processes.append(_start([*worker, "--nworkers", "1"], environment, folder / "w1"))
        processes.append(_start([*worker, "--no-nanny"], environment, folder / "w2"))
        address = json.loads(scheduler_file.read_text())["address"]
        with Client(address, timeout=60, set_as_default=False) as client:
            client.wait_for_workers(2, timeout=START_DEADLINE_S)
        yield Apart(address, tuple(processes))
    finally:
        _stop(processes)


def test_a_scheduler_and_workers_started_apart_give_the_serial_results(apart: Apart) -> None:
    items = [5, 1, 3, 2, 6, 0]
    serial = parallel_map(square_or_refuse, items, SERIAL)
    remote = parallel_map(square_or_refuse, items, Workers(scheduler=apart.address))
    assert [(o.index, o.value) for o in serial] == [(o.index, o.value) for o in remote]
    assert [type(o.error) for o in serial] == [type(o.error) for o in remote]
    assert str(remote[2].error) == "item 3: refused"


def test_processes_started_apart_listen_on_loopback_only(apart: Apart) -> None:
    assert apart.address.startswith("tcp://127.0.0.1:")
    listening: dict[int, list[str]] = {}
    for process in apart.processes:
        root = psutil.Process(process.pid)
        for member in [root, *root.children(recursive=True)]:
            connections = member.net_connections(kind="inet")
            listening[member.pid] = [
                c.laddr.ip for c in connections if c.status == psutil.CONN_LISTEN
            ]
    assert len(listening) >= 4  # scheduler, nanny and its worker, the worker without nanny
    assert all(listening[p.pid] for p in apart.processes)  # each serves on a port
    assert {ip for ips in listening.values() for ip in ips} == {"127.0.0.1"}


@pytest.mark.skipif(not openblas_threads(), reason="no OpenBLAS found loaded (Linux wheels)")
def test_workers_started_apart_compute_with_one_blas_thread(apart: Apart) -> None:
    found = values(
        parallel_map(worker_and_blas_threads, range(6), Workers(scheduler=apart.address))
    )
    assert len({address for address, _ in found}) == 2  # both workers, nanny or not
    assert all(threads and set(threads.values()) == {1} for _, threads in found), found


# --------------------------------------------------------------------------- refusals


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def test_an_unreachable_scheduler_is_one_line_naming_its_address() -> None:
    address = f"tcp://127.0.0.1:{_free_port()}"
    with pytest.raises(BrakeHilError) as refused:
        parallel_map(square_or_refuse, [1, 2], Workers(scheduler=address))
    assert address in str(refused.value) and "\n" not in str(refused.value)
    with pytest.raises(BrakeHilError, match="nonsense"):
        parallel_map(square_or_refuse, [1], Workers(scheduler="nonsense"))


def test_a_scheduler_without_workers_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(parallel, "SCHEDULER_TIMEOUT_S", 3.0)
    scheduler_file = tmp_path / "scheduler.json"
    arguments = ["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard"]
    arguments += ["--dashboard-address", "127.0.0.1:0"]
    processes = [
        _start(
            [*arguments, "--scheduler-file", str(scheduler_file)], dict(os.environ), tmp_path / "s"
        )
    ]
    try:
        _wait_for(scheduler_file.is_file, "scheduler file", processes)
        address = json.loads(scheduler_file.read_text())["address"]
        with pytest.raises(BrakeHilError, match="has no worker") as refused:
            parallel_map(square_or_refuse, [1, 2], Workers(scheduler=address))
        assert address in str(refused.value)
    finally:
        _stop(processes)


def test_the_command_line_exits_2_with_one_line_for_an_unreachable_scheduler() -> None:
    address = f"tcp://127.0.0.1:{_free_port()}"
    done = subprocess.run(
        [sys.executable, "-m", "brake_hil.cli", "regress", str(BAG), "--baseline"]
        + [str(PROJECT / "bags" / "baseline.json"), "--scheduler", address],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1 and address in done.stderr, done.stderr
    assert done.stderr.startswith("brake-hil regress: error: ")


def worker_settings(_item: int) -> tuple[str | None, bool, str]:
    """What a worker's own config and environment say (module level: workers import it)."""
    import dask

    return (
        os.environ.get("MALLOC_TRIM_THRESHOLD_"),
        bool(dask.config.get("distributed.worker.profile.enabled")),
        str(dask.config.get("distributed.admin.tick.interval")),
    )


def test_workers_run_without_the_dask_defaults_that_slow_a_diagnosis(tmp_path: Path) -> None:
    # The embedded cluster's workers: no 64 KiB malloc trim, no profiler, a 1 s tick.
    settings = values(parallel_map(worker_settings, [0, 1], Workers(jobs=2)))
    assert settings == [(None, False, "1s")] * 2
    # The same settings for a cluster of one's own, as a Dask config file it reads.
    import dask

    path = parallel.write_dask_config(tmp_path)
    read = dask.config.collect(paths=[str(path.parent)], env={})
    for dotted, value in parallel.LOCAL_CLUSTER_CONFIG.items():
        node = read
        for part in dotted.split("."):
            node = node[part]
        assert node == value, dotted
