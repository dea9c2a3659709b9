"""A diagnosis that fails on one case of a benchmark costs that case, not the run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from brake_hil.app import benchmark
from brake_hil.cli import main
from brake_hil.diagnosis.diagnose import Diagnosis


def test_an_internal_error_on_one_case_is_recorded_the_rest_scored_and_exit_is_1(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    made = main(
        ["cases", "--out", str(tmp_path / "set"), "--count", "2", "--seed", "5",
         "--kind", "null", "--pulsing-seconds", "3", "--serial"]
    )  # fmt: skip
    assert made == 0
    first, second = sorted(p.name for p in (tmp_path / "set" / "cases").iterdir())
    real = benchmark.diagnose

    def fails_on_the_first(recording: object, rig: object) -> Diagnosis:
        # fault injection: a bug of the diagnosis on one case (an SVD of a NaN Jacobian), the
        # real diagnosis on the other
        if f"cases/{first}/" in str(getattr(recording, "path", "")):
            raise ValueError("array must not contain infs or NaNs")
        return real(recording, rig)  # type: ignore[arg-type]

    monkeypatch.setattr(benchmark, "diagnose", fails_on_the_first)
    figures_path = tmp_path / "figures.json"
    status = main(["benchmark", str(tmp_path / "set"), "--serial", "--json", str(figures_path)])
    err = capsys.readouterr().err
    assert status == 1
    assert "the diagnosis failed on 1 case(s)" in err and err.rstrip().endswith(first)
    figures = json.loads(figures_path.read_text())
    assert figures["cases"] == 2 and figures["null_cases"] == 2
    (error,) = figures["errors"]
    assert error.startswith(f"{first}: internal error: ValueError: array must not contain")
    scored = {c["case"]: c for c in figures["per_case"]}
    assert scored[first]["effects"] == [] and scored[first]["confidence"] == 0.0
    assert scored[second]["error"] == "" and scored[second]["summary"]
