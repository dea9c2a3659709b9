"""Property: random damage to a good recording or rig file never gives a traceback, a hang or
a wrong answer: ``brake-hil`` answers what the undamaged parts support (exit 0) or refuses
with one line (exit 2), within 10 s.

About 100 recording and 150 rig examples (hypothesis' database off, so every run draws
afresh, but under ``CI=true`` the same ones each run); ``benchmarks/bench_fuzz.py`` runs many
more and prints the counts by outcome.
"""

from __future__ import annotations

import os
from pathlib import Path
import tempfile
from typing import Any

from hypothesis import HealthCheck, example, given, settings

from test.hostile import fuzzing
from test.hostile.harness import FAILURES


def _settings(examples: int) -> settings:
    # A developer's run draws fresh examples; CI (CI=true) draws the same ones every run, so a
    # landing is judged on the code, not on the draw (benchmarks/bench_fuzz.py explores more).
    return settings(
        max_examples=examples,
        deadline=None,
        database=None,
        derandomize=os.environ.get("CI", "").lower() == "true",
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )


@_settings(100)
@given(fuzzing.recording_damage)
# A byte flipped inside a zstd chunk: zstandard's ZstdError is no ValueError.
@example(([], ("flip", [(1.0, 1), (0.023348339548065814, 1)]), "compare"))
# A cut recording refused: the reader's note on the unfinished file was a second stderr line.
@example(([], ("truncate", 0.7768697535949292), "characterize"))
def test_damaged_recordings_are_answered_or_refused_in_one_line(
    damaged: tuple[list[tuple[Any, ...]], tuple[Any, ...] | None, str],
) -> None:
    ops, file_op, command = damaged
    with tempfile.TemporaryDirectory() as folder:
        run = fuzzing.recording_example(ops, file_op, command, Path(folder))
    assert run.outcome not in FAILURES, f"damage {damaged}\n{run.describe()}"


@_settings(150)
@given(fuzzing.rig_damage)
def test_damaged_rig_files_are_answered_or_refused_in_one_line(
    ops: list[tuple[Any, ...]],
) -> None:
    with tempfile.TemporaryDirectory() as folder:
        run = fuzzing.rig_example(ops, Path(folder))
    assert run.outcome not in FAILURES, f"damage {ops}\n{run.describe()}"
