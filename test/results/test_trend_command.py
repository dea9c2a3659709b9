"""``brake-hil trend``: the page and figures from a database; exit 2 and one line on bad input."""

from __future__ import annotations

from pathlib import Path
import re
import sqlite3

import numpy as np
import pytest

from brake_hil.app.trend import run_trend
from brake_hil.cli import main
from brake_hil.errors import BrakeHilError, OutputError
from brake_hil.report.trend_report import PAGE, figure_name
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
    assert out[1] == "  too few runs to say (3 diagnoses, 5 needed)"
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
    for rig in ("rig-1", "rig-2", "rig 3/new"):
        figure = report.parent / figure_name(rig)
        assert figure.stat().st_size > 10_000
        assert f'src="{figure.name}"' in page


def test_trend_of_one_rig_into_a_chosen_folder(database: Path, tmp_path: Path) -> None:
    result = run_trend(f"sqlite:///{database}", "rig-2", tmp_path / "out")
    assert [t.rig for t in result.rigs] == ["rig-2"]
    assert result.report_path == tmp_path / "out" / PAGE
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [PAGE, "trend_rig_2.png"]


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
        (_no_diagnosis, [], "no diagnosis stored"),
        (_no_diagnosis, ["--rig", "rig-9"], "no diagnosis of rig 'rig-9' stored"),
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
