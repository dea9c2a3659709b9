"""The benchmark's Done-when figures, scored on hand-made verdicts; ``--keep``."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from brake_hil.app import benchmark
from brake_hil.app.benchmark import CaseResult, is_right, read_case_labels, score
from brake_hil.cli import main

HOSE_KEYS = ["hose.youngs_modulus", "hose.wall", "hose.diameter"]


def _result(case: str, effects: tuple[str, ...], confidence: float, **verdict: Any) -> CaseResult:
    return CaseResult(
        case, effects, confidence, 1.0, {"x_c": 0.2}, {"x_c": 0.02}, verdict=dict(verdict)
    )


def _labels() -> dict[str, dict[str, object]]:
    return {
        "000": {"family": "a", "kind": "null", "air": "degassed", "expected_effects": []},
        "001": {"family": "a", "kind": "null", "air": "rig_file", "expected_effects": []},
        "002": {"family": "a", "kind": "null", "air": "rig_file", "expected_effects": []},
        "003": {"family": "a", "kind": "out_of_tolerance", "key": "hose.wall", "ratio": 1.15,
                "expected_effects": []},
        "004": {"family": "a", "kind": "out_of_tolerance", "key": "bore.length", "ratio": 0.85,
                "expected_effects": []},
        "005": {"family": "b", "kind": "out_of_tolerance", "key": "hose.wall", "ratio": 0.8,
                "expected_effects": []},
        "006": {"family": "b", "kind": "more_air", "ratio": 2.5, "expected_effects": []},
        "007": {"family": "b", "kind": "more_air", "ratio": 2.2, "expected_effects": []},
        "008": {"family": "b", "kind": "single", "expected_effects": ["valve_turbulence"]},
        "009": {"family": "b", "kind": "unexplained", "expected_effects": ["unexplained"]},
    }  # fmt: skip


def _results() -> list[CaseResult]:
    more = {"air": {"state": "more_than_rig_file", "ratio": 2.4}}
    hose = {"rig_values": [{"quantity": "hose_stiffness", "keys": HOSE_KEYS, "ratio": 0.8}]}
    return [
        _result("000", (), 0.55, rig_values=[]),  # right
        _result("001", ("entrained_air",), 0.95, **more),  # false positive and "more air"
        _result("002", (), 0.65, air={"state": "as_rig_file"}),  # right
        _result("003", (), 0.75, **hose),  # found
        _result("004", (), 0.85),  # no rig_values field yet: not found, no crash
        _result("005", ("hose_compliance",), 0.92, **hose),  # an effect named: not found
        _result("006", ("entrained_air",), 0.97, **more),  # more air found
        _result("007", (), 0.6, air={"state": "as_rig_file"}),  # missed
        _result("008", ("valve_turbulence",), 0.99),  # right
        _result("009", ("unexplained",), 0.5),  # right
    ]


def test_each_new_figure_is_scored_by_the_cases_kind() -> None:
    figures = score(_results(), _labels())
    assert figures["null_cases"] == 3 and figures["false_positive_rate_null"] == pytest.approx(
        1 / 3
    )
    assert (
        figures["null_cases_degassed"] == 1 and figures["false_positive_rate_null_degassed"] == 0
    )
    assert figures["null_cases_rig_file"] == 2
    assert figures["false_positive_rate_null_rig_file"] == 0.5
    assert figures["more_air_false_alarm_rate_rig_file_nulls"] == 0.5
    assert figures["out_of_tolerance_cases"] == 3
    assert figures["out_of_tolerance_found"] == pytest.approx(1 / 3)
    assert figures["more_air_cases"] == 2 and figures["more_air_recall"] == 0.5
    assert figures["top1_accuracy_single"] == 1.0 and figures["unexplained_recall"] == 1.0
    # at >= 0.9: 001 (wrong), 005 (wrong), 006 (right), 008 (right)
    assert figures["sure_verdicts"] == 4 and figures["wrong_sure_count"] == 2
    assert figures["wrong_sure_verdicts"] == ["001", "005"]
    assert figures["wrong_share_of_sure_verdicts"] == 0.5
    table = {tuple(row["confidence"]): row for row in figures["reliability"]}
    assert sorted(table) == [  # the bins with a verdict (none below 0.5)
        (0.5, 0.6),
        (0.6, 0.7),
        (0.7, 0.8),
        (0.8, 0.9),
        (0.9, 1.0),
    ]
    assert table[(0.5, 0.6)]["cases"] == 2 and table[(0.5, 0.6)]["accuracy"] == 1.0
    assert table[(0.6, 0.7)]["cases"] == 2 and table[(0.6, 0.7)]["accuracy"] == 0.5
    assert table[(0.8, 0.9)]["accuracy"] == 0.0  # 004: no rig_values, not found
    assert table[(0.9, 1.0)]["cases"] == 4
    assert table[(0.9, 1.0)]["mean_confidence"] == pytest.approx((0.95 + 0.92 + 0.97 + 0.99) / 4)
    by_family = figures["by_family"]
    assert sorted(by_family) == ["a", "b"]
    assert by_family["a"]["null_cases"] == 3 and by_family["b"]["null_cases"] == 0
    assert by_family["a"]["out_of_tolerance_found"] == 0.5
    assert by_family["b"]["out_of_tolerance_found"] == 0.0
    assert by_family["b"]["more_air_recall"] == 0.5
    json.dumps(figures)  # JSON-ready


def test_a_far_value_is_right_beside_no_effect_but_the_rig_files_own_air() -> None:
    label = {"kind": "out_of_tolerance", "key": "hose.wall", "expected_effects": []}
    hose = [{"keys": HOSE_KEYS}]
    assert is_right(_result("0", (), 0.7, rig_values=hose), label)
    assert not is_right(_result("0", ("hose_compliance",), 0.7, rig_values=hose), label)
    assert not is_right(_result("0", (), 0.7, rig_values=[{"keys": ["bore.length"]}]), label)
    assert not is_right(_result("0", (), 0.7, rig_values=None), label)
    assert not is_right(_result("0", (), 0.7, rig_values=[{"quantity": "x"}]), label)
    # the rig file's own air, said as the rig file's, beside the far value: as on a null
    as_file = {"state": "as_rig_file"}
    air = {**label, "air": "rig_file"}
    assert is_right(_result("0", ("entrained_air",), 0.7, rig_values=hose, air=as_file), air)
    more = {"state": "more_than_rig_file"}
    assert not is_right(_result("0", ("entrained_air",), 0.7, rig_values=hose, air=more), air)
    assert not is_right(_result("0", ("entrained_air",), 0.7, rig_values=[], air=as_file), air)


def test_labels_without_kinds_are_read_from_their_effects(tmp_path: Path) -> None:
    path = tmp_path / "labels.json"
    path.write_text(json.dumps({
        "000": {"effects": []}, "001": {"effects": ["unexplained"]},
        "002": {"effects": ["a"]}, "003": {"effects": ["a", "b"]},
        "004": {"effects": [], "kind": "more_air", "ratio": 2.0},
    }))  # fmt: skip
    kinds = {case: entry["kind"] for case, entry in read_case_labels(path).items()}
    assert kinds == {"000": "null", "001": "unexplained", "002": "single", "003": "pair",
                     "004": "more_air"}  # fmt: skip


class _Fake:
    """Stands in for a diagnosis: what the benchmark reads of it."""

    effects = ("entrained_air",)
    confidence = 0.8
    baseline = SimpleNamespace(held_out_rms={"x_c": 0.1}, held_out_cost=1.0)
    improved = SimpleNamespace(held_out_rms={"x_c": 0.05})
    hypotheses = ()
    summary = SimpleNamespace(as_dict=lambda: {"noise": 1.0})

    def as_dict(self) -> dict[str, object]:
        return {
            "verdict": {"effects": ["entrained_air"], "confidence": 0.8,
                        "air": {"state": "more_than_rig_file"}},
            "decision_inputs": {"noise": 1.0},
        }  # fmt: skip


def test_keep_writes_each_cases_diagnosis_and_refuses_a_used_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    made = main(
        ["cases", "--out", str(tmp_path / "set"), "--count", "1", "--seed", "5",
         "--kind", "more_air", "--pulsing-seconds", "1.5", "--serial"]
    )  # fmt: skip
    assert made == 0
    monkeypatch.setattr(benchmark, "diagnose", lambda recording, rig: _Fake())
    keep, figures_path = tmp_path / "kept", tmp_path / "figures.json"
    status = main(["benchmark", str(tmp_path / "set"), "--serial", "--keep", str(keep),
                   "--json", str(figures_path)])  # fmt: skip
    out = capsys.readouterr().out
    assert status == 0
    (case,) = sorted(p.name for p in (tmp_path / "set" / "cases").iterdir())
    kept = json.loads((keep / case / "diagnosis.json").read_text())
    assert kept == _Fake().as_dict()
    figures = json.loads(figures_path.read_text())
    assert figures["more_air_cases"] == 1 and figures["more_air_recall"] == 1.0
    assert figures["per_case"][0]["verdict"]["air"]["state"] == "more_than_rig_file"
    assert "more-air recall" in out and "100.0 %" in out
    again = main(["benchmark", str(tmp_path / "set"), "--serial", "--keep", str(keep)])
    err = capsys.readouterr().err
    assert again == 2 and "not empty" in err and err.count("\n") == 1


def test_scoring_follows_the_verdicts_air() -> None:
    as_file = {"air": {"state": "as_rig_file", "ratio": 1.2}}
    more = {"air": {"state": "more_than_rig_file", "ratio": 2.6}}
    labels = {
        "000": {"family": "a", "kind": "null", "air": "rig_file", "expected_effects": []},
        "001": {"family": "a", "kind": "null", "air": "rig_file", "expected_effects": []},
        "002": {"family": "a", "kind": "null", "air": "degassed", "expected_effects": []},
        "003": {"family": "a", "kind": "null", "air": "rig_file", "expected_effects": []},
        "004": {"family": "a", "kind": "more_air", "ratio": 2.5, "expected_effects": []},
    }
    results = [
        _result("000", ("entrained_air",), 0.95, **as_file),  # the rig file's air: right
        _result("001", ("entrained_air",), 0.95, **more),  # "bleed" on a null: wrong
        _result("002", ("entrained_air",), 0.95, **as_file),  # degassed: no air to name
        _result("003", ("entrained_air", "hose_compliance"), 0.95, **as_file),  # a hose too
        _result("004", ("entrained_air",), 0.97, **more),  # more air, found: right
    ]
    assert is_right(results[0], {**labels["000"], "kind": "null"})
    figures = score(results, labels)
    assert figures["false_positive_rate_null"] == pytest.approx(3 / 4)
    assert figures["false_positive_rate_null_rig_file"] == pytest.approx(2 / 3)
    assert figures["more_air_recall"] == 1.0
    assert figures["wrong_sure_verdicts"] == ["001", "002", "003"]
