"""``brake-hil trend``: the page and figures from a database; exit 2 and one line on bad input."""

from __future__ import annotations

import json
from pathlib import Path
import re
import sqlite3

import numpy as np
import pytest

from brake_hil.app.trend import run_trend
from brake_hil.cli import main
from brake_hil.errors import BrakeHilError, OutputError
from brake_hil.report.embed import DATA_URI_PREFIX
from brake_hil.report.trend_report import PAGE
from brake_hil.results.identity import RecordingIdentity
from brake_hil.results.store import open_store
from test.results.fleets import DAY_NS, START_NS, Run, document, steady_fleet, wearing_fleet


def _record(database: Path | str, rig: str, fleet: list[Run]) -> None:
    with open_store(database) as store:
        for number, run in enumerate(fleet):
            start = START_NS + number * DAY_NS
            identity = RecordingIdentity(
                path=f"bags/{rig}/run_{number:03d}",
                content_hash=f"{rig}-{number}",
                start_ns=start,
                end_ns=start + 18 * 10**9,
                rig_name=rig,
                rig_hash=f"{rig}-file",
                rig_path=f"config/{rig}.yaml",
            )
            store.record_diagnosis(identity, document(run))


@pytest.fixture(scope="module")
def database(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """rig-1 wears over 30 days, rig-2 stays steady, rig 3 has 3 runs."""
    path = tmp_path_factory.mktemp("lab") / "results.sqlite"
    _record(path, "rig-1", wearing_fleet(np.random.default_rng(11), 30))
    _record(path, "rig-2", steady_fleet(np.random.default_rng(12), 20))
    _record(path, "rig 3/new", steady_fleet(np.random.default_rng(13), 3))
    return path


def test_trend_prints_each_rigs_findings_and_writes_the_page(
    database: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["trend", "--db", str(database)]) == 0
    out = capsys.readouterr().out.splitlines()
    report = database.parent / "trend" / PAGE
    assert out[0] == "rig 3/new: 3 diagnoses"
    assert out[1] == "  3 runs: too few to test a trend; 8 needed"
    rig_1 = out[out.index("rig-1: 30 diagnoses") + 1 : out.index("rig-2: 20 diagnoses")]
    assert rig_1[0].startswith("  caliper stiffness fell 1")
    assert rig_1[1].startswith("  fluid air fraction rose")
    assert rig_1[2].startswith("  seal stick-slip grew over 30 runs")
    assert out[out.index("rig-2: 20 diagnoses") + 1] == (
        "  no value or effect left its band over 20 runs"
    )
    assert out[-1] == f"report: {report}"
    page = report.read_text()
    assert "caliper stiffness fell" in page and "the piston seals: wear" in page
    # One self-contained file: a figure per rig inside it, nothing beside it.
    assert [p.name for p in report.parent.iterdir()] == [PAGE]
    sources = re.findall(r'<img src="([^"]+)"', page)
    assert len(sources) == 3
    assert all(s.startswith(DATA_URI_PREFIX) and len(s) > 10_000 for s in sources)


def test_trend_of_one_rig_into_a_chosen_folder(database: Path, tmp_path: Path) -> None:
    result = run_trend(f"sqlite:///{database}", "rig-2", tmp_path / "out")
    assert [t.rig for t in result.rigs] == ["rig-2"]
    assert result.report_path == tmp_path / "out" / PAGE
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [PAGE]


def test_a_link_out_of_the_folder_is_not_written_through(database: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / PAGE).symlink_to(tmp_path / "elsewhere.html")
    with pytest.raises(OutputError, match="outside"):
        run_trend(database, "rig-2", out)
    assert not (tmp_path / "elsewhere.html").exists()


def _other_schema(path: Path) -> None:
    connection = sqlite3.connect(path)
    connection.execute("CREATE TABLE logbook (day TEXT)")
    connection.commit()
    connection.close()


def _no_diagnosis(path: Path) -> None:
    with open_store(path) as store:
        store.record_failure("diagnosis", path.parent / "gone", path.parent / "gone.yaml", "x")


@pytest.mark.parametrize(
    ("make", "arguments", "message"),
    [
        (None, [], "no such results database"),
        (lambda p: p.write_bytes(b"not a database" * 100), [], "not an SQLite database"),
        (_other_schema, [], r"not a brake_hil results database \(its tables: logbook\)"),
        (_no_diagnosis, [], "no diagnosis, regression or comparison stored"),
        (
            _no_diagnosis,
            ["--rig", "rig-9"],
            "no diagnosis, regression or comparison of rig 'rig-9' stored",
        ),
    ],
    ids=["missing", "garbage", "another-schema", "only-failures", "unknown-rig"],
)
def test_trend_refuses_bad_input_with_one_line_and_exit_2(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    make: object,
    arguments: list[str],
    message: str,
) -> None:
    path = tmp_path / "results.sqlite"
    if callable(make):
        make(path)
    assert main(["trend", "--db", str(path), *arguments]) == 2
    captured = capsys.readouterr()
    [line] = captured.err.splitlines()
    assert line.startswith(f"brake-hil trend: error: {path}: ")
    assert re.search(message, line)
    assert not (tmp_path / "trend").exists()


def test_trend_refuses_another_database_url(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["trend", "--db", "mysql://lab/results"]) == 2
    assert capsys.readouterr().err == (
        "brake-hil trend: error: mysql://lab/results: not a database brake_hil knows (give a "
        "file path, sqlite:///path or postgresql://USER@HOST:PORT/NAME), not mysql\n"
    )


def test_run_trend_of_an_unknown_rig_names_the_rigs_there(database: Path) -> None:
    with pytest.raises(BrakeHilError, match=r"\(rigs: 'rig 3/new', 'rig-1', 'rig-2'\)"):
        run_trend(database, "rig-9")


def _nightly(database: Path, nights: int, drift_from: int) -> None:
    """A nightly regression of two recordings, one model file version a night; from night
    ``drift_from`` on, the block force's NRMSE of the first recording rises 0.03."""
    with open_store(database) as store:
        for night in range(nights):
            for name in ("one_washer_open", "five_washer_open"):
                identity = RecordingIdentity(
                    path=f"bags/{name}",
                    content_hash=name,
                    start_ns=START_NS,
                    end_ns=START_NS + 18 * 10**9,
                    rig_name="rig-1",
                    rig_hash=f"model-{night}",
                    rig_path="out/improved_model.json",
                )
                worse = 0.03 if name == "one_washer_open" and night >= drift_from else 0.0
                metrics = {
                    channel: {"ptp_ratio_pct": 99.0, "tau_over_T_pct": 0.5, "nrmse": 0.05}
                    for channel in ("p_b", "F_k", "x_c")
                }
                metrics["F_k"] = {**metrics["F_k"], "nrmse": 0.05 + worse}
                store.record_metrics("regression", identity, {"model": metrics})


def test_trend_of_a_nightly_regression_draws_each_recordings_metrics(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    database = tmp_path / "results.sqlite"
    _nightly(database, 6, drift_from=4)
    assert main(["trend", "--db", str(database)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "bags/five_washer_open (regression): 6 runs"
    assert out[1] == "  every metric within its tolerance of the first run over 6 runs"
    assert out[2] == "bags/one_washer_open (regression): 6 runs"
    assert out[3] == (
        "  F_k nrmse: 0.08 in run 6 of 6 against 0.05 in the first run, beyond its "
        "tolerance ±0.005 (2 runs beyond it)"
    )
    page = (tmp_path / "trend" / PAGE).read_text()
    assert "no diagnosis" not in page
    assert page.count(f'<img src="{DATA_URI_PREFIX}') == 2


def test_a_nightly_is_held_against_the_baseline_when_given(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    database = tmp_path / "results.sqlite"
    _nightly(database, 3, drift_from=99)
    baseline = tmp_path / "baseline.json"
    metrics = {
        channel: {"ptp_ratio_pct": 99.0, "tau_over_T_pct": 0.5, "nrmse": 0.04}
        for channel in ("p_b", "F_k", "x_c")
    }
    baseline.write_text(
        json.dumps(
            {
                "tolerances": {"ptp_ratio_pct": 0.5, "tau_over_T_pct": 0.25, "nrmse": 0.02},
                "bags": {Path("bags/one_washer_open").resolve().as_posix(): {"metrics": metrics}},
            }
        )
    )
    assert main(["trend", "--db", str(database), "--baseline", str(baseline)]) == 0
    out = capsys.readouterr().out.splitlines()
    index = out.index("bags/one_washer_open (regression): 3 runs")
    assert out[index + 1] == "  every metric within its tolerance of the baseline over 3 runs"
