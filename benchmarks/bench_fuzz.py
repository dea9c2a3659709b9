"""The fuzz suite's long run: many damaged recordings and rig files, counts by outcome.

The same strategies and checks as ``test/hostile/test_fuzz.py`` (see
``test/hostile/fuzzing.py``), with many more examples and no stop at the first failure:
every example is run, its outcome counted (answer, refused, and the failures bad_refusal,
traceback, hang, wrong), the slowest time printed, and each failure's damage listed for
replay. Exit status 1 when any example failed.

Run from the checkout::

    .venv/bin/python benchmarks/bench_fuzz.py --recordings 600 --rigs 1000
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path
import sys
import tempfile
import time
from typing import Any

from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

PROJECT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(PROJECT))

from test.hostile import fuzzing  # noqa: E402
from test.hostile.harness import FAILURES, Run  # noqa: E402


def _run(kind: str, strategy: st.SearchStrategy[Any], examples: int, seed_value: int) -> list[Run]:
    runs: list[Run] = []
    failures: list[str] = []

    @settings(
        max_examples=examples,
        deadline=None,
        database=None,
        suppress_health_check=list(HealthCheck),
        phases=[p for p in settings.default.phases if p.name != "shrink"],
    )
    @given(strategy)
    def one(damaged: Any) -> None:
        with tempfile.TemporaryDirectory() as folder:
            if kind == "recording":
                run = fuzzing.recording_example(*damaged, Path(folder))
            else:
                run = fuzzing.rig_example(damaged, Path(folder))
        runs.append(run)
        if run.outcome in FAILURES:
            failures.append(f"{kind} {damaged!r}\n{run.describe()}")

    seed(seed_value)(one)()
    for failure in failures:
        print(failure, file=sys.stderr)
    return runs


def main() -> int:
    """Run the long fuzz and print the counts by outcome; 1 when anything failed."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recordings", type=int, default=400)
    parser.add_argument("--rigs", type=int, default=600)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    fuzzing.baseline()
    failed = False
    for kind, strategy, count in (
        ("recording", fuzzing.recording_damage, args.recordings),
        ("rig", fuzzing.rig_damage, args.rigs),
    ):
        started = time.perf_counter()
        runs = _run(kind, strategy, count, args.seed)
        counts = Counter(run.outcome for run in runs)
        slowest = max((run.cpu_seconds for run in runs), default=0.0)
        print(
            f"{kind:9s} {len(runs):5d} examples in {time.perf_counter() - started:6.1f} s: "
            + ", ".join(f"{o} {counts[o]}" for o in ("answer", "refused", *FAILURES))
            + f"; slowest {slowest:.2f} s CPU"
        )
        failed |= any(counts[o] for o in FAILURES)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
