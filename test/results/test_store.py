"""The results database: round trips, replacement, all-or-nothing writes, refusals, concurrency."""

from __future__ import annotations

from collections.abc import Iterator
import json
import math
import multiprocessing
from pathlib import Path
import sqlite3
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
import pytest

from brake_hil import __version__
from brake_hil.errors import BrakeHilError
from brake_hil.results import store as store_module
from brake_hil.results.identity import RecordingIdentity
from brake_hil.results.store import (
    APPLICATION,
    SCHEMA_VERSION,
    ResultsStore,
    database_path,
    open_store,
)
from test.conftest import PROJECT
from test.results.fleets import real_document

EMPTY = {"recordings": 0, "runs": 0, "calibration": 0, "metrics": 0, "effects": 0}


def identity(number: int = 0, rig: str = "rig A") -> RecordingIdentity:
    start = 1_700_000_000 * 10**9 + number * 86_400 * 10**9
    return RecordingIdentity(
        path=f"bags/run_{number:03d}",
        content_hash=f"{number:064x}",
        start_ns=start,
        end_ns=start + 18 * 10**9,
        rig_name=rig,
        rig_hash=f"{rig}-hash",
        rig_path=f"{rig}.yaml",
    )


@pytest.fixture(params=["sqlite", "postgresql"])
def database(request: pytest.FixtureRequest, tmp_path: Path) -> str:
    """A new database on each backend: an SQLite file, a PostgreSQL database (conftest.py)."""
    if request.param == "sqlite":
        return str(tmp_path / "results.sqlite")
    return str(request.getfixturevalue("postgres_url"))


@pytest.fixture
def store(database: str) -> Iterator[ResultsStore]:
    """An empty store on each backend."""
    with open_store(database) as opened:
        yield opened


def test_a_diagnosis_reads_back_as_written_also_through_plain_sqlite(tmp_path: Path) -> None:
    document = real_document()
    path = tmp_path / "results.sqlite"
    with open_store(path) as store:
        run = store.record_diagnosis(identity(), document)
        [row] = store.diagnoses()
    assert row.run_id == run
    assert row.effects == ("seal_stick_slip",)
    assert row.confidence == document["verdict"]["confidence"]
    assert row.explanation == document["verdict"]["explanation"]
    assert row.tool_version == __version__
    assert row.start_ns == identity().start_ns
    calibration = document["calibration"]
    assert {c.name: c.multiplier for c in row.calibration} == calibration["multipliers"]
    assert {c.name: c.posterior_sigma for c in row.calibration} == calibration["posterior_sigma"]
    improved = document["improved"]["parameters"]
    assert {c.name: c.improved_multiplier for c in row.calibration} == {
        name: improved[f"calibration.{name}"] for name in calibration["multipliers"]
    }
    assert row.metrics["baseline"]["F_k"] == document["baseline"]["metrics"]["F_k"]
    assert row.metrics["improved"]["x_c"] == document["improved"]["metrics"]["x_c"]
    assert [h.effect for h in row.hypotheses] == [h["effect"] for h in document["hypotheses"]]
    assert [h.named for h in row.hypotheses] == [True] + [False] * 8
    assert row.hypotheses[0].parameters == document["hypotheses"][0]["parameters"]

    raw = sqlite3.connect(path)  # an independent reader
    meta = dict(raw.execute("SELECT key, value FROM meta"))
    assert meta == {"application": APPLICATION, "schema_version": str(SCHEMA_VERSION)}
    status, effects, confidence = raw.execute(
        "SELECT status, effects, confidence FROM runs"
    ).fetchone()
    assert (status, json.loads(effects), confidence) == ("ok", ["seal_stick_slip"], 0.867)
    nrmse = raw.execute(
        "SELECT nrmse FROM metrics WHERE model = 'improved' AND channel = 'F_k'"
    ).fetchone()[0]
    assert nrmse == document["improved"]["metrics"]["F_k"]["nrmse"]
    improvement = raw.execute(
        "SELECT held_out_improvement FROM effects WHERE effect = 'seal_stick_slip'"
    ).fetchone()[0]
    assert improvement == 105.012
    raw.close()


def test_running_again_replaces_the_run_rather_than_adding_one(store: ResultsStore) -> None:
    document = real_document()
    store.record_diagnosis(identity(), document)
    before = store.counts()
    document["verdict"]["confidence"] = 0.5
    store.record_diagnosis(identity(), document)
    assert store.counts() == before
    assert [row.confidence for row in store.diagnoses()] == [0.5]
    good = store.diagnoses()[0].run_id
    bag = PROJECT / "bags" / "one_washer_open"
    assert store.record_failure("diagnosis", bag, None, "first") != good
    store.record_failure("diagnosis", bag, None, "again")
    assert [f.error for f in store.failures()] == ["again"]


def test_another_tool_version_adds_a_run_and_the_trend_sees_the_latest(
    store: ResultsStore, monkeypatch: pytest.MonkeyPatch
) -> None:
    store.record_diagnosis(identity(), real_document())
    monkeypatch.setattr(store_module, "__version__", "9.9.9")
    store.record_diagnosis(identity(), real_document())
    assert store.counts()["runs"] == 2
    assert [row.tool_version for row in store.diagnoses()] == ["9.9.9"]
    assert len(store.diagnoses(latest_only=False)) == 2


def test_diagnoses_come_in_recording_time_order_and_by_rig(store: ResultsStore) -> None:
    for number in (3, 1, 2):
        store.record_diagnosis(identity(number), real_document())
    store.record_diagnosis(identity(7, rig="rig B"), real_document())
    assert [row.recording_path for row in store.diagnoses("rig A")] == [
        "bags/run_001",
        "bags/run_002",
        "bags/run_003",
    ]
    assert store.rigs() == ["rig A", "rig B"]
    assert [row.rig_name for row in store.diagnoses("rig B")] == ["rig B"]
    assert store.diagnoses("rig C") == []


def test_a_nan_metric_is_refused_and_nothing_of_the_run_is_written(store: ResultsStore) -> None:
    document = real_document()
    document["improved"]["metrics"]["F_k"]["nrmse"] = math.nan
    refused = r"^bags/run_000: diagnosis not stored: improved\.metrics\.F_k\.nrmse: not a finite"
    with pytest.raises(BrakeHilError, match=refused):
        store.record_diagnosis(identity(), document)
    assert store.counts() == EMPTY


def test_an_error_mid_write_leaves_the_earlier_run_as_it_was(
    store: ResultsStore, monkeypatch: pytest.MonkeyPatch
) -> None:
    store.record_diagnosis(identity(), real_document())
    before = store.counts()

    def fail(*args: object) -> None:
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(ResultsStore, "_insert_metrics", staticmethod(fail))
    changed = real_document()
    changed["verdict"]["confidence"] = 0.1
    with pytest.raises(RuntimeError, match="disk on fire"):
        store.record_diagnosis(identity(), changed)
    with pytest.raises(RuntimeError, match="disk on fire"):
        store.record_diagnosis(identity(1), changed)
    assert store.counts() == before
    assert [row.confidence for row in store.diagnoses()] == [0.867]


def test_a_failure_is_kept_as_failed_without_metrics_and_never_as_a_diagnosis(
    store: ResultsStore, tmp_path: Path
) -> None:
    store.record_failure("diagnosis", tmp_path / "gone", tmp_path / "gone.yaml", "boom\n  twice")
    [failed] = store.failures()
    assert (failed.kind, failed.error, failed.rig_name) == ("diagnosis", "boom twice", "gone")
    assert store.diagnoses() == []
    assert store.metrics(failed.run_id) == {}
    assert store.counts()["metrics"] == 0
    store.record_failure("diagnosis", tmp_path / "gone", None, "no rig file beside it")
    assert [f.rig_name for f in store.failures()] == ["gone", "no rig file"]


def test_regression_metrics_are_stored_per_model_and_channel(store: ResultsStore) -> None:
    metrics = real_document()["baseline"]["metrics"]
    with_cycles = {c: {**m, "cycles": 12.0} for c, m in metrics.items()}
    run = store.record_metrics("regression", identity(), {"model": with_cycles})
    assert store.metrics(run) == {"model": metrics}
    again = store.record_metrics("comparison", identity(), {"model": metrics})
    assert again != run and store.counts()["runs"] == 2
    partial = {"model": {"p_b": {"ptp_ratio_pct": 99.0, "nrmse": 0.1}}}
    with pytest.raises(BrakeHilError, match=r"^bags/run_001: regression not stored: metrics"):
        store.record_metrics("regression", identity(1), partial)
    with pytest.raises(BrakeHilError, match="diagnosis"):
        store.record_metrics("diagnosis", identity(1), {"model": metrics})
    assert store.counts()["runs"] == 2


@pytest.mark.parametrize(
    ("url", "message"),
    [
        ("mysql+pymysql://u:secret@h/db", r"^mysql\+pymysql://u:\*\*\*@h/db: not a database"),
        ("mongodb://h/db", "not a database brake_hil knows .* not mongodb"),
        ("sqlite://", "give the database file as sqlite:///path"),
    ],
)
def test_a_url_of_another_database_is_refused_in_one_line(url: str, message: str) -> None:
    with pytest.raises(BrakeHilError, match=message) as refused:
        open_store(url)
    assert "\n" not in str(refused.value) and "secret" not in str(refused.value)


def test_sqlite_urls_name_relative_and_absolute_files(tmp_path: Path) -> None:
    assert database_path("sqlite:///out/r.db") == Path("out/r.db")
    assert database_path(f"sqlite:///{tmp_path}/r.db") == tmp_path / "r.db"
    with open_store(f"sqlite:///{tmp_path}/r.db") as store:
        store.record_diagnosis(identity(), real_document())
    with open_store(tmp_path / "r.db", create=False) as store:
        assert len(store.diagnoses()) == 1


def _another_schema(path: Path) -> None:
    connection = sqlite3.connect(path)
    connection.execute("CREATE TABLE measurements (t REAL, value REAL)")
    connection.commit()
    connection.close()


def _another_version(path: Path) -> None:
    open_store(path).close()
    connection = sqlite3.connect(path)
    connection.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    connection.commit()
    connection.close()


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda p: p.write_bytes(b"\x00garbage" * 300), "not an SQLite database"),
        (lambda p: p.write_bytes(b"SQLite format 3\x00" + b"\xff" * 2000), "not a usable"),
        (_another_schema, r"not a brake_hil results database \(its tables: measurements\)"),
        (_another_version, r"results schema 99, .* \(written by a newer brake_hil\)"),
        (lambda p: p.mkdir(), "not a regular file"),
    ],
    ids=["garbage", "cut-sqlite", "another-schema", "newer-schema", "folder"],
)
def test_a_file_that_is_not_our_database_is_refused_naming_it(
    tmp_path: Path, make: Any, message: str
) -> None:
    path = tmp_path / "results.sqlite"
    make(path)
    with pytest.raises(BrakeHilError, match=message) as refused:
        open_store(path)
    assert str(refused.value).startswith(str(path))


def test_a_missing_database_is_made_only_when_asked(tmp_path: Path) -> None:
    path = tmp_path / "new" / "results.sqlite"
    with pytest.raises(BrakeHilError, match="no such results database"):
        open_store(path, create=False)
    assert not path.exists()
    open_store(path).close()
    assert path.is_file()
    empty = tmp_path / "empty.sqlite"
    empty.touch()
    with pytest.raises(BrakeHilError, match="an empty database, no results in it"):
        open_store(empty, create=False)
    with open_store(empty) as store:
        assert store.counts() == EMPTY


def _append(url: str, numbers: list[int], start: object) -> None:
    start.wait()  # type: ignore[attr-defined]
    with open_store(url) as store:
        for number in numbers:
            store.record_diagnosis(identity(number), real_document())


def test_two_processes_appending_at_once_lose_nothing_and_double_nothing(
    database: str,
) -> None:
    context = multiprocessing.get_context("fork")
    start = context.Barrier(2)
    shared = list(range(500, 510))  # both write these: the same run keys, racing
    plans = [list(range(i * 100, i * 100 + 20)) + shared for i in range(2)]
    workers = [context.Process(target=_append, args=(database, p, start)) for p in plans]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join(timeout=120)
    assert [worker.exitcode for worker in workers] == [0, 0]
    with open_store(database, create=False) as store:
        counts = store.counts()
        paths = sorted(row.recording_path for row in store.diagnoses(latest_only=False))
    assert counts["runs"] == counts["recordings"] == 50
    assert counts["effects"] == 50 * 9
    expected = sorted({f"bags/run_{n:03d}" for plan in plans for n in plan})
    assert paths == expected


# --------------------------------------------------------------------------- fuzz

_PATHS = (
    ("verdict",),
    ("verdict", "effects"),
    ("verdict", "confidence"),
    ("verdict", "explanation"),
    ("calibration",),
    ("calibration", "multipliers", "caliper_stiffness"),
    ("calibration", "prior_sigma", "air_fraction"),
    ("calibration", "posterior_sigma", "hose_stiffness"),
    ("baseline", "metrics"),
    ("baseline", "metrics", "p_b", "nrmse"),
    ("improved", "metrics", "F_k", "ptp_ratio_pct"),
    ("improved", "parameters", "calibration.valve_resistance"),
    ("hypotheses",),
    ("hypotheses", 0, "effect"),
    ("hypotheses", 2, "held_out_improvement"),
    ("hypotheses", 4, "parameters"),
)
_JUNK = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**400), 10**400),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=5),
    st.lists(st.integers(), max_size=2),
    st.dictionaries(st.text(max_size=3), st.floats(), max_size=2),
    st.just("__delete__"),
)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(path=st.sampled_from(_PATHS), junk=_JUNK)
def test_a_spoiled_document_is_stored_whole_or_refused_with_nothing_written(
    tmp_path: Path, path: tuple[str | int, ...], junk: object
) -> None:
    document = real_document()
    parent: Any = document
    for key in path[:-1]:
        parent = parent[key]
    if junk == "__delete__":
        del parent[path[-1]]
    else:
        parent[path[-1]] = junk
    with open_store(tmp_path / "fuzz.sqlite") as store:
        before = store.counts()
        try:
            run = store.record_diagnosis(identity(), document)
        except BrakeHilError as err:
            assert "\n" not in str(err)
            assert store.counts() == before
        else:
            [row] = [r for r in store.diagnoses() if r.run_id == run]
            assert math.isfinite(row.confidence)
            assert all(
                math.isfinite(v)
                for model in row.metrics.values()
                for channel in model.values()
                for v in channel.values()
            )


def test_a_later_failed_attempt_never_replaces_a_good_result(store: ResultsStore) -> None:
    from brake_hil.results.identity import identify

    bag = PROJECT / "bags" / "one_washer_open"
    rig = PROJECT / "bags" / "one_washer_open.rig.yaml"
    good = store.record_diagnosis(identify(bag, rig), real_document())
    kept = store.record_failure("diagnosis", bag, rig, "worker killed")
    assert kept == good
    assert [row.run_id for row in store.diagnoses()] == [good] and store.failures() == []
    failed = store.record_failure("diagnosis", bag, None, "no rig file beside it")
    assert failed != good and len(store.failures()) == 1  # another rig file: its own run
