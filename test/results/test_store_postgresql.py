"""The results database on PostgreSQL: the SQLite store's contract on a real server.

The session's server (``conftest.py``) listens on a Unix socket only; each test has its own
database. What is read back is checked against the same rows written to an SQLite file, and
through psycopg directly (an independent reader).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
import re
import socket
import subprocess
import sys

import numpy as np
import pytest

from brake_hil.cli import main
from brake_hil.errors import BrakeHilError
from brake_hil.report.trend_report import PAGE
from brake_hil.results.store import (
    APPLICATION,
    SCHEMA_VERSION,
    DiagnosisRow,
    open_store,
)
from test.results.conftest import PostgresServer
from test.results.fleets import real_document, steady_fleet, wearing_fleet
from test.results.test_store import EMPTY, identity
from test.results.test_trend_command import _record


def _comparable(row: DiagnosisRow) -> DiagnosisRow:
    """A diagnosis less what differs between two databases (its id, when written)."""
    return dataclasses.replace(row, run_id=0, written_at="")


def test_each_kind_of_row_reads_back_as_from_sqlite(postgres_url: str, tmp_path: Path) -> None:
    metrics = real_document()["baseline"]["metrics"]
    read = {}
    for url in (postgres_url, str(tmp_path / "results.sqlite")):
        with open_store(url) as store:
            store.record_diagnosis(identity(0), real_document())
            store.record_diagnosis(identity(1, rig="rig B"), real_document())
            regression = store.record_metrics("regression", identity(0), {"model": metrics})
            comparison = store.record_metrics("comparison", identity(1), {"model": metrics})
            store.record_failure("diagnosis", tmp_path / "gone", None, "no rig file\n beside it")
            read[url] = (
                [_comparable(row) for row in store.diagnoses()],
                store.metrics(regression),
                store.metrics(comparison),
                [dataclasses.replace(f, run_id=0, written_at="") for f in store.failures()],
                store.rigs(),
                store.counts(),
            )
    on_postgresql, on_sqlite = read.values()
    assert on_postgresql == on_sqlite
    diagnoses, regression_metrics, _, failures, rigs, counts = on_postgresql
    assert [row.rig_name for row in diagnoses] == ["rig A", "rig B"]
    assert regression_metrics == {"model": metrics}
    assert [f.error for f in failures] == ["no rig file beside it"]
    assert rigs == ["rig A", "rig B"]
    assert counts["runs"] == 5

    import psycopg

    with psycopg.connect(postgres_url) as raw:  # an independent reader
        assert dict(raw.execute("SELECT key, value FROM meta").fetchall()) == {
            "application": APPLICATION,
            "schema_version": str(SCHEMA_VERSION),
        }
        start_ns, duration = raw.execute(
            "SELECT start_ns, pg_typeof(duration_s)::text FROM recordings WHERE path = %s",
            (identity(0).path,),
        ).fetchone()
        assert (start_ns, duration) == (identity(0).start_ns, "double precision")
        improvement = raw.execute(
            "SELECT held_out_improvement FROM effects WHERE effect = 'seal_stick_slip' LIMIT 1"
        ).fetchone()
        assert improvement == (105.012,)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        ("CREATE TABLE measurements (t REAL, value REAL)", r"\(its tables: measurements\)"),
        ("CREATE TABLE meta (key TEXT, value TEXT)", r"\(a meta table of another\)"),
        (None, r"results schema 99, this brake_hil reads 1 \(written by a newer brake_hil\)"),
    ],
    ids=["another-schema", "another-meta", "newer-schema"],
)
def test_a_database_that_is_not_ours_is_refused_naming_it(
    postgres_url: str, make: str | None, message: str
) -> None:
    import psycopg

    if make is None:
        open_store(postgres_url).close()
        make = "UPDATE meta SET value = '99' WHERE key = 'schema_version'"
    with psycopg.connect(postgres_url, autocommit=True) as raw:
        raw.execute(make)
    with pytest.raises(BrakeHilError, match=message) as refused:
        open_store(postgres_url)
    assert str(refused.value).startswith(postgres_url + ": ")
    assert "\n" not in str(refused.value)


def test_an_empty_database_is_given_tables_only_when_asked(postgres_url: str) -> None:
    with pytest.raises(BrakeHilError, match="an empty database, no results in it"):
        open_store(postgres_url, create=False)
    with open_store(postgres_url) as store:
        assert store.counts() == EMPTY
        assert store.path is None and store.name == postgres_url


def test_a_wrong_password_is_refused_without_showing_it(postgres_server: PostgresServer) -> None:
    postgres_server.admin("DROP ROLE IF EXISTS lab")
    postgres_server.admin("CREATE ROLE lab LOGIN PASSWORD 'right'")
    [(hba_file,)] = postgres_server.admin("SHOW hba_file")
    hba = Path(str(hba_file))
    kept = hba.read_text()
    hba.write_text("local all lab scram-sha-256\n" + kept)
    try:
        postgres_server.admin("SELECT pg_reload_conf()")
        url = f"postgresql://lab:hunter2@/postgres?host={postgres_server.socket_dir}"
        with pytest.raises(BrakeHilError, match="authentication failed") as refused:
            open_store(url)
        assert str(refused.value).startswith("postgresql://lab:***@/postgres?host=")
        assert "hunter2" not in str(refused.value) and "\n" not in str(refused.value)
    finally:
        hba.write_text(kept)
        postgres_server.admin("SELECT pg_reload_conf()")


def _closed_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@pytest.mark.parametrize(
    ("url", "message"),
    [
        (
            "postgresql://lab:p%zz@/results?host={socket}",
            r"postgresql://lab:\*\*\*@/results\?host=.*: not a PostgreSQL URL: invalid "
            r"percent-encoded token: \"\*\*\*\"",
        ),
        (
            "postgresql://postgres:secret@/results?host={socket}&colour=blue",
            r"not a PostgreSQL URL: invalid URI query parameter: \"colour\"",
        ),
        (
            "postgresql://postgres:secret@127.0.0.1:{port}/results",
            r"postgresql://postgres:\*\*\*@127\.0\.0\.1:\d+/results: PostgreSQL server not "
            r"reachable \(.*Connection refused",
        ),
        (
            "postgresql://postgres@/no_such_db?host={socket}&password=secret",
            r"/no_such_db\?host=.*&password=\*\*\*: no such database \(database \"no_such_db\" "
            r"does not exist\)",
        ),
    ],
    ids=["bad-url", "unknown-parameter", "unreachable", "no-such-database"],
)
def test_the_command_line_refuses_a_bad_database_in_one_line_with_exit_2(
    postgres_server: PostgresServer, tmp_path: Path, url: str, message: str
) -> None:
    url = url.format(socket=postgres_server.socket_dir, port=_closed_port())
    done = subprocess.run(
        [sys.executable, "-m", "brake_hil.cli", "trend", "--db", url, "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=tmp_path,
    )
    assert done.returncode == 2, done.stderr
    assert done.stdout == ""
    [line] = done.stderr.splitlines()
    assert line.startswith("brake-hil trend: error: postgresql://")
    assert "secret" not in line and "p%zz" not in line
    assert re.search(message, line), line


def test_trend_reads_the_same_trend_from_postgresql_as_from_sqlite(
    postgres_url: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    sqlite_file = tmp_path / "lab" / "results.sqlite"
    for database in (postgres_url, sqlite_file):
        _record(database, "rig-1", wearing_fleet(np.random.default_rng(11), 30))
        _record(database, "rig-2", steady_fleet(np.random.default_rng(12), 20))
        _record(database, "rig 3/new", steady_fleet(np.random.default_rng(13), 3))
    monkeypatch.chdir(tmp_path)
    assert main(["trend", "--db", str(sqlite_file)]) == 0
    from_sqlite = capsys.readouterr().out.splitlines()
    assert main(["trend", "--db", postgres_url]) == 0  # default output: trend/ here
    from_postgresql = capsys.readouterr().out.splitlines()
    assert from_postgresql[:-1] == from_sqlite[:-1]
    assert "rig-1: 30 diagnoses" in from_sqlite
    assert from_sqlite[-1] == f"report: {sqlite_file.parent / 'trend' / PAGE}"
    assert from_postgresql[-1] == f"report: {Path('trend') / PAGE}"
    assert postgres_url in (tmp_path / "trend" / PAGE).read_text()
