"""compare and characterize on the bundled ramp and sweep, through the command line's
``main`` (in this process: a subprocess per command costs seconds on a busy runner)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

from brake_hil.cli import main
from brake_hil.io.recording_writer import write_recording
from brake_hil.topics import (
    BLOCK_FORCE,
    BORE_PRESSURE,
    CALIPER_DISPLACEMENT,
    MASTER_CYLINDER_PRESSURE,
)
from test.conftest import CONFIG, PROJECT

BAGS = PROJECT / "bags"


class Done(NamedTuple):
    returncode: int
    stdout: str
    stderr: str


@pytest.fixture
def brake_hil(capsys: pytest.CaptureFixture[str]):  # type: ignore[no-untyped-def]
    def run(*args: str | Path) -> Done:
        status = main([str(arg) for arg in args])
        captured = capsys.readouterr()
        return Done(status, captured.out, captured.err)

    return run


def test_compare_scores_the_ramp_and_the_sweep_and_draws_their_figures(
    tmp_path: Path, brake_hil
) -> None:  # type: ignore[no-untyped-def]
    for name, kind, metric, figure in (
        ("ramp_one_washer", "ramp", "static map", "ramp"),
        ("sweep_one_washer", "sweep", "frequency response", "sweep"),
    ):
        plot = tmp_path / f"{name}.png"
        done = brake_hil(
            "compare", BAGS / name, "--json", tmp_path / f"{name}.json", "--plot", plot
        )
        assert done.returncode == 0, done.stdout + done.stderr
        assert "segments found" in done.stdout and metric in done.stdout
        assert "over non idle segments:" in done.stdout
        document = json.loads((tmp_path / f"{name}.json").read_text())
        assert document["basis"] == "non_idle_segments"
        assert kind in [s["kind"] for s in document["segments"]]
        assert set(document["metrics"]) == {"p_b", "F_k", "x_c"}
        for written in (plot, tmp_path / f"{name}.{figure}.png"):
            assert written.stat().st_size > 10_000 and f"plot written to {written}" in done.stdout


def test_characterize_gives_the_seal_per_band_of_the_sweep_and_refuses_a_ramp(
    tmp_path: Path, brake_hil
) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "c.json"
    done = brake_hil("characterize", BAGS / "sweep_one_washer", "--json", out)
    assert done.returncode == 0, done.stdout + done.stderr
    document = json.loads(out.read_text())
    assert document["segments"] == []  # no steady pulsing: the contract's list is empty
    assert [s["kind"] for s in document["segments_found"]] == ["ramp", "sweep"]
    (sweep,) = document["sweeps"]
    assert len(sweep["bands"]) == 19 and "k_eh_sigma" in sweep["bands"][0]
    assert "the seal per band" in done.stdout
    refused = brake_hil("characterize", BAGS / "ramp_one_washer")
    assert refused.returncode == 2
    errors = [line for line in refused.stderr.splitlines() if "error:" in line]
    assert len(errors) == 1 and "needs steady pulsing at 5 Hz or a sweep" in errors[0]
    assert "Traceback" not in refused.stderr


def test_a_recording_of_nothing_but_idle_is_refused_in_one_line(tmp_path: Path, brake_hil) -> None:  # type: ignore[no-untyped-def]
    time = np.arange(0.0, 3.0, 1e-3)
    noise = np.random.default_rng(0).normal(0.0, 1.5e3, time.size)
    bag = write_recording(
        tmp_path / "idle",
        time,
        {
            MASTER_CYLINDER_PRESSURE: 5e3 + noise,
            BORE_PRESSURE: 5e3 + noise[::-1],
            BLOCK_FORCE: 5.0 + noise * 1e-3,
            CALIPER_DISPLACEMENT: -1e-6 + noise * 1e-12,
        },
    )
    done = brake_hil("compare", bag, "--rig", CONFIG / "rig_default.yaml")
    assert done.returncode == 2, done.stdout + done.stderr
    errors = [line for line in done.stderr.splitlines() if "error:" in line]
    assert len(errors) == 1 and "nothing but idle" in errors[0] and str(bag) in errors[0]
