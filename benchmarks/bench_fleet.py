"""Many recordings on Dask: the blind diagnosis of a case set, four ways, the same verdicts.

Diagnoses every case of a directory made by ``brake-hil cases`` (``cases/NNN/recording`` and
``rig.yaml``) with ``brake-hil benchmark``'s own per-case function
(:func:`brake_hil.app.benchmark.run_cases` over
:func:`~brake_hil.app.parallel.parallel_map`), in each variant:

* ``serial``: in this process, one after the other;
* ``local1``, ``local2``: an embedded Dask ``LocalCluster`` of 1 or 2 worker processes, started
  and closed inside the timed map (as ``brake-hil benchmark --jobs N`` does);
* ``apart``: ``dask scheduler`` and ``dask worker --nworkers 2 --nthreads 1`` started as their
  own processes on 127.0.0.1 before the timed map (a running cluster; their start-up is
  printed apart) and killed after it.

Prints each variant's wall time, its speed-up against ``serial``, the diagnosis seconds summed
over the cases, and the overhead per recording: worker time not spent diagnosing (workers x
wall - diagnosis seconds) over the recordings: start-up, scheduling, transfers, and workers idle
at the end. Checks that every variant gives the same verdicts (effects, confidence, error),
says so, and exits 1 when not. Wall times depend on the machine and its load.

    .venv/bin/brake-hil cases --count 52 --seed 303 --out DIR
    .venv/bin/python benchmarks/bench_fleet.py DIR [--limit N] [--variants serial,local2]
        [--json F]
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
import json
import os
from pathlib import Path
import signal
import subprocess
import sys
import tempfile
import time

PROJECT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(PROJECT))

from brake_hil.app.benchmark import CaseResult, run_cases  # noqa: E402
from brake_hil.app.parallel import LOOPBACK, SERIAL, Workers, write_dask_config  # noqa: E402

VARIANTS = {
    "serial": "serial (this process)",
    "local1": "LocalCluster, 1 worker",
    "local2": "LocalCluster, 2 workers",
    "apart": "scheduler + 2 workers apart",
}
START_DEADLINE_S = 120.0
"""Seconds the scheduler and workers started apart have to come up."""


@dataclass(frozen=True)
class Run:
    """One variant's map over the cases."""

    variant: str
    workers: int  # worker processes
    wall_s: float
    results: list[CaseResult]

    @property
    def diagnosis_s(self) -> float:
        """Seconds of diagnosis summed over the cases (each case's own wall time)."""
        return sum(result.seconds for result in self.results)

    def overhead_per_recording(self) -> float:
        """Worker seconds not spent diagnosing, per recording (s)."""
        return (self.workers * self.wall_s - self.diagnosis_s) / len(self.results)


@contextmanager
def dask_apart(workers: int, log_dir: Path) -> Iterator[str]:
    """A ``dask scheduler`` and ``dask worker`` on loopback, as processes; yields the address.

    Every listening socket on 127.0.0.1 (``--dashboard-address`` too: ``--no-dashboard``
    still serves HTTP, on every interface by default). Killed, process groups and all, after.
    """
    from distributed import Client

    dask = Path(sys.executable).with_name("dask")
    scheduler_file = log_dir / "scheduler.json"
    common = ["--host", LOOPBACK, "--no-dashboard", "--dashboard-address", f"{LOOPBACK}:0"]
    common += ["--scheduler-file", str(scheduler_file)]
    # the embedded cluster's settings (LOCAL_CLUSTER_CONFIG), as a user would give a cluster
    environment = dict(os.environ, PYTHONPATH=str(PROJECT), DASK_CONFIG=str(log_dir))
    write_dask_config(log_dir)
    commands = [
        ["scheduler", "--port", "0", *common],
        ["worker", "--nworkers", str(workers), "--nthreads", "1", *common],
    ]
    processes: list[subprocess.Popen[bytes]] = []
    try:
        for name, command in zip(("scheduler", "worker"), commands):
            with (log_dir / f"{name}.log").open("wb") as log:
                processes.append(
                    subprocess.Popen(
                        [str(dask), *command],
                        cwd=PROJECT,
                        env=environment,
                        stdout=log,
                        stderr=subprocess.STDOUT,
                        start_new_session=True,
                    )
                )
            deadline = time.monotonic() + START_DEADLINE_S
            while not scheduler_file.is_file():
                if time.monotonic() > deadline or processes[0].poll() is not None:
                    raise RuntimeError(f"no Dask scheduler came up; see {log_dir}")
                time.sleep(0.1)
        address = json.loads(scheduler_file.read_text(encoding="utf-8"))["address"]
        with Client(address, timeout=60, set_as_default=False) as client:
            client.wait_for_workers(workers, timeout=START_DEADLINE_S)
        yield str(address)
    finally:
        for process in processes:
            try:
                os.killpg(process.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            process.wait(timeout=30)


def run_variant(variant: str, cases: list[Path]) -> tuple[Run, float | None]:
    """Diagnose ``cases`` the ``variant`` way; the run and the cluster's start-up (apart)."""
    if variant == "apart":
        with tempfile.TemporaryDirectory(prefix="bench_fleet_") as folder:
            began = time.perf_counter()
            with dask_apart(2, Path(folder)) as address:
                started = time.perf_counter() - began
                run = timed(variant, 2, cases, Workers(scheduler=address))
            return run, started
    workers = {"serial": SERIAL, "local1": Workers(jobs=1), "local2": Workers(jobs=2)}[variant]
    return timed(variant, workers.jobs or 1, cases, workers), None


def timed(variant: str, count: int, cases: list[Path], workers: Workers) -> Run:
    """One timed map of the per-case diagnosis."""
    began = time.perf_counter()
    results = run_cases(cases, workers)
    return Run(variant, count, time.perf_counter() - began, results)


def verdicts(run: Run) -> list[tuple[str, tuple[str, ...], float, str]]:
    """What must not depend on where a case ran: case, effects, confidence, error."""
    return [(r.case, r.effects, r.confidence, r.error) for r in run.results]


def main() -> None:
    """Parse the arguments, run each variant, print the figures, check the verdicts agree."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("directory", type=Path, help="made by 'brake-hil cases'")
    parser.add_argument("--limit", type=int, help="the first N cases only (by folder)")
    parser.add_argument(
        "--variants",
        default=",".join(VARIANTS),
        help=f"comma-separated, of {', '.join(VARIANTS)} (default: all, in that order)",
    )
    parser.add_argument("--json", type=Path, help="also write the figures here as JSON")
    args = parser.parse_args()
    chosen = [name.strip() for name in args.variants.split(",") if name.strip()]
    unknown = [name for name in chosen if name not in VARIANTS]
    cases = sorted(p for p in (args.directory / "cases").glob("*") if p.is_dir())
    cases = cases[: args.limit] if args.limit is not None else cases
    if unknown or not chosen or not cases:
        what = f"unknown variants {unknown}" if unknown or not chosen else "no cases"
        parser.error(f"{what} ({args.directory})")
    print(
        f"fleet: {len(cases)} recordings of {args.directory} ({cases[0].name}-{cases[-1].name}), "
        f"{os.cpu_count()} cores, one BLAS thread per worker"
    )
    print(
        f"{'variant':30s}{'workers':>8s}{'wall s':>9s}{'speed-up':>10s}{'diagnosis s':>13s}"
        f"{'overhead s/rec':>16s}"
    )
    runs: list[Run] = []
    figures = []
    for variant in chosen:
        run, started = run_variant(variant, cases)
        runs.append(run)
        serial = next((r for r in runs if r.variant == "serial"), None)
        speedup = serial.wall_s / run.wall_s if serial is not None else float("nan")
        print(
            f"{VARIANTS[variant]:30s}{run.workers:8d}{run.wall_s:9.1f}{speedup:9.2f}x"
            f"{run.diagnosis_s:13.1f}{run.overhead_per_recording():16.2f}"
            + (f"  (started in {started:.1f} s, not in wall)" if started is not None else "")
        )
        figures.append(
            {
                "variant": variant,
                "workers": run.workers,
                "wall_s": run.wall_s,
                "speedup_vs_serial": speedup,
                "diagnosis_s": run.diagnosis_s,
                "overhead_s_per_recording": run.overhead_per_recording(),
                "cluster_start_s": started,
            }
        )
    same = all(verdicts(run) == verdicts(runs[0]) for run in runs)
    names = ", ".join(run.variant for run in runs)
    print(f"same verdicts in every variant ({names}): {'yes' if same else 'NO'}")
    for result in runs[0].results:
        verdict = ", ".join(result.effects) or "none"
        refused = f"; refused: {result.error}" if result.error else ""
        print(f"  case {result.case}: {verdict} ({result.confidence:.2f}){refused}")
    if args.json is not None:
        document = {
            "directory": str(args.directory),
            "recordings": len(cases),
            "cpu_count": os.cpu_count(),
            "variants": figures,
            "same_verdicts": same,
            "verdicts": {r.case: list(r.effects) for r in runs[0].results},
        }
        args.json.write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")
        print(f"json written to {args.json}")
    if not same:
        for run in runs[1:]:
            differing = [a for a, b in zip(verdicts(runs[0]), verdicts(run)) if a != b]
            print(f"  {run.variant} differs from {runs[0].variant} on {differing}")
        raise SystemExit(1)


if __name__ == "__main__":
    main()
