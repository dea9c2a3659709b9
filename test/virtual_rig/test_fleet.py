"""The virtual lab of ``brake-hil fleet``: one rig wearing, one steady, recorded daily."""

from __future__ import annotations

import json
import os
from pathlib import Path
import subprocess
import sys

from brake_hil.app.recordings import find_recordings, rig_beside
from brake_hil.physics.rig import load_rig
from brake_hil.results.identity import identify
from brake_hil.virtual_rig.fleet import AIR_GROWTH, SEAL_WEAR, STEADY_SEAL, plan_fleet

PROJECT = Path(__file__).resolve().parents[2]


def _strengths(runs: list, rig: str, effect: str) -> list[float]:
    return [
        next((e.strength for e in run.effects if e.name == effect), 0.0)
        for run in runs
        if run.rig_name == rig
    ]


def test_one_rig_wears_from_run_to_run_and_the_other_stays_steady() -> None:
    plan = plan_fleet(runs=6, seed=3)
    assert plan == plan_fleet(runs=6, seed=3)  # every draw from the seed
    seal = _strengths(plan, "rig-1", "seal_stick_slip")
    air = _strengths(plan, "rig-1", "entrained_air")
    assert seal[0] == SEAL_WEAR[0] and seal[-1] == SEAL_WEAR[1]
    assert air[0] == AIR_GROWTH[0] and air[-1] == AIR_GROWTH[1]
    assert seal == sorted(seal) and air == sorted(air)
    assert _strengths(plan, "rig-2", "seal_stick_slip") == [STEADY_SEAL] * 6
    assert _strengths(plan, "rig-2", "entrained_air") == [0.0] * 6
    for rig in ("rig-1", "rig-2"):
        starts = [run.start for run in plan if run.rig_name == rig]
        assert starts == sorted(starts) and len(set(starts)) == 6
        errors = {json.dumps(run.parameter_errors) for run in plan if run.rig_name == rig}
        assert len(errors) == 1  # one truth per rig; only the day's viscosity changes


def test_the_fleet_command_writes_dated_recordings_with_their_rig_files(tmp_path: Path) -> None:
    out = tmp_path / "lab"
    env = {**os.environ, "PYTHONPATH": str(PROJECT)}
    command = [sys.executable, "-m", "brake_hil.cli", "fleet", "--out", str(out)]
    options = ["--runs", "2", "--pulsing-seconds", "1", "--serial"]
    done = subprocess.run(
        command + options, capture_output=True, text=True, timeout=600, env=env, check=False
    )
    assert done.returncode == 0, done.stderr
    recordings = find_recordings([out])
    assert [str(r.relative_to(out)) for r in recordings] == [
        "rig-1/run-01",
        "rig-1/run-02",
        "rig-2/run-01",
        "rig-2/run-02",
    ]
    identities = [identify(r, rig_beside(r)) for r in recordings]
    assert [i.rig_name for i in identities] == ["rig-1", "rig-1", "rig-2", "rig-2"]
    assert identities[0].rig_hash == identities[1].rig_hash  # one rig file per rig
    assert identities[1].start_ns - identities[0].start_ns == 86_400 * 10**9  # a day apart
    assert load_rig(rig_beside(recordings[0])).name == "rig-1"
    truth = json.loads((out / "truth.json").read_text())
    assert sorted(truth["runs"]) == [str(r.relative_to(out)) for r in recordings]
    again = subprocess.run(
        command + options, capture_output=True, text=True, timeout=600, env=env, check=False
    )
    assert again.returncode == 2 and again.stderr.count("\n") == 1
    assert "not empty" in again.stderr
