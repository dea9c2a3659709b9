"""``brake-hil diagnose DIR``: many recordings on a Dask LocalCluster, results in SQLite."""

from __future__ import annotations

import os
from pathlib import Path
import shutil
import sqlite3
import subprocess
import sys

import pytest

BAGS = Path(__file__).resolve().parents[2] / "bags"
DEADLINE_S = 900  # two diagnoses on a busy 2-core runner, generously


def _brake_hil(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(BAGS.parent)}
    return subprocess.run(
        [sys.executable, "-m", "brake_hil.cli", *args],
        capture_output=True,
        text=True,
        timeout=DEADLINE_S,
        cwd=cwd,
        env=env,
        check=False,
    )


def _rows(database: Path, sql: str) -> list[tuple[object, ...]]:
    with sqlite3.connect(database) as connection:
        return list(connection.execute(sql))


@pytest.fixture
def lab(tmp_path: Path) -> Path:
    """lab/rig-a/{one_washer_open, one_washer_lti}, each with its rig file; lab/rig-b/broken."""
    for name in ("one_washer_open", "one_washer_lti"):
        shutil.copytree(BAGS / name, tmp_path / "lab" / "rig-a" / name)
        shutil.copy(BAGS / f"{name}.rig.yaml", tmp_path / "lab" / "rig-a")
    broken = tmp_path / "lab" / "rig-b" / "broken"
    broken.mkdir(parents=True)
    (broken / "broken_0.mcap").write_bytes(b"\x89MCAP0\r\nnot a recording at all")
    shutil.copy(BAGS / "one_washer_open.rig.yaml", broken.parent / "broken.rig.yaml")
    return tmp_path / "lab"


def test_a_folder_is_diagnosed_on_dask_a_bad_recording_named_and_the_rest_kept(
    lab: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    done = _brake_hil("diagnose", str(lab), "--out", str(out), "--jobs", "2", cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    failed = [line for line in done.stderr.splitlines() if line.startswith("brake-hil diagnose:")]
    assert len(failed) == 1 and "rig-b/broken" in failed[0], done.stderr
    assert "Traceback" not in done.stderr
    assert "diagnosed 2 of 3 recordings" in done.stdout
    for name in ("one_washer_open", "one_washer_lti"):
        assert (out / "rig-a" / name / "diagnosis.json").is_file()
        assert (out / "rig-a" / name / "report.html").is_file()
    database = out / "results.sqlite"
    runs = _rows(
        database, "SELECT status, rig_name, error FROM runs ORDER BY status DESC, rig_name"
    )
    assert [(status, rig) for status, rig, _ in runs] == [
        ("ok", "nominal one-washer rig"),
        ("ok", "one-washer rig as simulated (truth differs from nominal)"),
        ("failed", "nominal one-washer rig"),
    ]
    assert runs[2][2] and "broken" in str(runs[2][2])
    assert _rows(database, "SELECT count(*) FROM metrics")[0][0] == 2 * 2 * 3

    # The same recording diagnosed again with the same version replaces its rows.
    before = _rows(database, "SELECT count(*) FROM runs")[0][0]
    again = _brake_hil(
        "diagnose",
        str(lab / "rig-a" / "one_washer_lti"),
        "--out",
        str(tmp_path / "again"),
        "--db",
        str(database),
        cwd=tmp_path,
    )
    assert again.returncode == 0, again.stderr
    assert f"results appended to {database}" in again.stdout
    assert _rows(database, "SELECT count(*) FROM runs")[0][0] == before


def test_a_pattern_that_names_no_recording_exits_2_with_one_line(tmp_path: Path) -> None:
    done = _brake_hil("diagnose", str(tmp_path / "nothing-*"), "--serial", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "no recording matches" in done.stderr
