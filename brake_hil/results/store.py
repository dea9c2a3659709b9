"""The results database: every diagnosis, regression and comparison, one row set per run.

Two backends, one store (:mod:`.backends`): SQLite from the standard library, one file (a
path, or ``sqlite:///path``; the default, beside the outputs), or a PostgreSQL server
(``postgresql://USER@HOST:PORT/NAME``, libpq's URL, e.g. a lab's shared database). Tables
(schema :data:`SCHEMA_VERSION`, in ``meta`` with the application's name):

* ``recordings``: a recording by its content hash (:mod:`brake_hil.results.identity`), its
  last path, first and last log time (ns) and duration (s);
* ``runs``: one command on one recording against one rig file: kind (``diagnosis``,
  ``regression``, ``comparison``), rig name and file hash, tool version, when written (UTC),
  status ``ok`` or ``failed`` with the error's line; a diagnosis adds its verdict (effects
  as JSON), confidence and explanation. At most one run per (kind, recording, rig file, tool
  version): running again replaces it;
* ``calibration``: a diagnosis's calibrated multipliers (over the rig file's value, 1 =
  nominal) with their prior (the rig file's tolerance) and posterior log-sigmas, and the
  improved model's multiplier of the same value;
* ``metrics``: the paper's Table 4-5 metrics per model (``baseline``, ``improved``,
  ``model``) and channel;
* ``effects``: a diagnosis's hypotheses: held-out improvement, score, whether the verdict
  names them, fitted parameters (JSON).

A run is written in one transaction after its document was checked, so a refused document or
an error mid-write leaves nothing of it; a failed command is kept as ``failed``, never with
metrics. Several processes may append at once: an SQLite file is in WAL mode and a writer
waits up to :data:`BUSY_TIMEOUT_S` for another's transaction; on PostgreSQL two writers of
the same run key take turns on the key's advisory lock, others write side by side. A
database that is not ours (no ``meta`` of this application) or of a newer schema is refused.

The schema and that check are in :mod:`.schema`, the documents' checks in :mod:`.documents`,
the rows read back in :mod:`.rows`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
import json
from pathlib import Path
from types import TracebackType
from typing import Any

from brake_hil import __version__
from brake_hil.analysis.comparison import SUMMARY_KEYS
from brake_hil.errors import BrakeHilError
from brake_hil.results.backends import BUSY_TIMEOUT_S, Database, database_path, open_database
from brake_hil.results.documents import (
    KeyRefusedError,
    check_diagnosis,
    check_metrics,
    checked_mapping,
)
from brake_hil.results.identity import RecordingIdentity, identify_loosely
from brake_hil.results.rows import (
    CalibrationValue,
    DiagnosisRow,
    FailedRun,
    HypothesisRow,
    Metrics,
    MetricsRun,
)
from brake_hil.results.schema import APPLICATION, KINDS, SCHEMA_VERSION, TABLES, one_line, prepare

__all__ = [
    "APPLICATION",
    "BUSY_TIMEOUT_S",
    "KINDS",
    "SCHEMA_VERSION",
    "CalibrationValue",
    "DiagnosisRow",
    "FailedRun",
    "HypothesisRow",
    "Metrics",
    "MetricsRun",
    "ResultsStore",
    "database_path",
    "open_store",
]


# --------------------------------------------------------------------------- the door


def open_store(url_or_path: str | Path, *, create: bool = True) -> ResultsStore:
    """Open (or, with ``create``, make) a results database.

    Args:
        url_or_path: the file, ``sqlite:///path``, or ``postgresql://USER@HOST:PORT/NAME``
            (libpq's URL: ``?host=/socket/dir``, ``sslmode=``, ... as libpq takes them).
        create: make the file (and its folder) when missing, and the tables in a database
            without any; without, a missing file or an empty database is refused.

    Raises:
        BrakeHilError: an unknown URL scheme; a missing file without ``create``; a file that
            is not an SQLite database; a server not reached, a login refused, a database that
            does not exist; a database of another application or of a newer schema.
        OutputError: the file cannot be made.
    """
    database = open_database(url_or_path, create=create)
    try:
        prepare(database, create)
    except BaseException:
        database.close()
        raise
    return ResultsStore(database)


def _run_key(kind: str, recording_hash: str, rig_hash: str, version: str) -> str:
    """A run's key as one text: what a writer locks on PostgreSQL."""
    return "\x1f".join(("brake_hil run", kind, recording_hash, rig_hash, version))


# --------------------------------------------------------------------------- the store


class ResultsStore:
    """An open results database (:func:`open_store`); a context manager that closes it.

    Args:
        database: the connection (each write takes its transaction).

    Attributes:
        name: the file, or the server's URL with the password masked.
        path: the file (``None``: a PostgreSQL database).
    """

    def __init__(self, database: Database) -> None:
        self._connection = database
        self.name = database.name
        self.path = database.path

    def __enter__(self) -> ResultsStore:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Close the database (SQLite: the last to close folds the WAL file back into it)."""
        self._connection.close()

    # ------------------------------------------------------------------ writing

    def record_diagnosis(self, recording: RecordingIdentity, document: Mapping[str, Any]) -> int:
        """Store a diagnosis (the content of its ``diagnosis.json``); return the run's id.

        A run of the same recording, rig file and tool version is replaced.

        Raises:
            BrakeHilError: the document is refused (nothing is written).
        """
        try:
            checked = check_diagnosis(document)
        except KeyRefusedError as err:
            raise BrakeHilError(f"{recording.path}: diagnosis not stored: {err}") from err
        with self._connection.transaction() as db:
            run = self._new_run(db, "diagnosis", recording)
            db.execute(
                "UPDATE runs SET effects = ?, confidence = ?, explanation = ? WHERE id = ?",
                (json.dumps(list(checked.effects)), checked.confidence, checked.explanation, run),
            )
            db.executemany(
                "INSERT INTO calibration (run, name, multiplier, prior_sigma, posterior_sigma, "
                "improved_multiplier) VALUES (?, ?, ?, ?, ?, ?)",
                [
                    (
                        run,
                        c.name,
                        c.multiplier,
                        c.prior_sigma,
                        c.posterior_sigma,
                        c.improved_multiplier,
                    )
                    for c in checked.calibration
                ],
            )
            self._insert_metrics(db, run, checked.metrics)
            db.executemany(
                "INSERT INTO effects (run, effect, named, held_out_improvement, score, "
                "parameters) VALUES (?, ?, ?, ?, ?, ?)",
                [
                    (
                        run,
                        h.effect,
                        int(h.named),
                        h.held_out_improvement,
                        h.score,
                        json.dumps(dict(h.parameters), allow_nan=False),
                    )
                    for h in checked.hypotheses
                ],
            )
        return run

    def record_metrics(self, kind: str, recording: RecordingIdentity, metrics: Metrics) -> int:
        """Store a regression's or comparison's metrics; return the run's id.

        Args:
            kind: ``regression`` or ``comparison``.
            recording: what was replayed or compared, and against which rig file.
            metrics: model name (e.g. ``model``) -> channel -> metric -> value; the seed's
                three metrics (:data:`~brake_hil.analysis.comparison.SUMMARY_KEYS`) are kept.

        Raises:
            BrakeHilError: another kind, or a metric missing or not finite (nothing written).
        """
        if kind not in KINDS[1:]:
            raise BrakeHilError(f"metrics of {kind!r} are not stored: regression or comparison")
        try:
            models = checked_mapping(metrics, "metrics")
            if not models:
                raise KeyRefusedError("metrics", "no model")
            checked = {model: check_metrics(v, f"metrics.{model}") for model, v in models.items()}
        except KeyRefusedError as err:
            raise BrakeHilError(f"{recording.path}: {kind} not stored: {err}") from err
        with self._connection.transaction() as db:
            run = self._new_run(db, kind, recording)
            self._insert_metrics(db, run, checked)
        return run

    def record_failure(
        self, kind: str, recording_path: Path, rig_path: Path | None, error: str
    ) -> int:
        """Store that ``kind`` failed on a recording (status ``failed``, no metrics).

        The recording and rig file (``None``: none was found) are identified as far as they
        can be (:func:`~brake_hil.results.identity.identify_loosely`). It replaces a failed
        run of the same recording, rig file and tool version, never a good one: a good result
        already recorded is not lost to a later attempt that failed (a full disk, a killed
        worker); the command says that attempt failed. Returns the run kept.

        Raises:
            BrakeHilError: an unknown kind.
        """
        if kind not in KINDS:
            raise BrakeHilError(f"unknown kind of run {kind!r} (known: {', '.join(KINDS)})")
        recording = identify_loosely(recording_path, rig_path)
        key = (kind, recording.content_hash, recording.rig_hash, __version__)
        with self._connection.transaction() as db:
            db.lock(_run_key(*key))
            good = db.execute(
                "SELECT id FROM runs WHERE kind = ? AND recording_hash = ? AND rig_hash = ? "
                "AND tool_version = ? AND status = 'ok'",
                key,
            ).fetchone()
            if good is not None:
                return int(good[0])
            run = self._new_run(db, kind, recording, error=one_line(error))
        return run

    def _new_run(
        self,
        db: Database,
        kind: str,
        recording: RecordingIdentity,
        error: str | None = None,
    ) -> int:
        """Upsert the recording, drop the run this one replaces, insert the run.

        Two writers of the same run key take turns (SQLite: one writer at a time; PostgreSQL:
        the key's advisory lock), so the second replaces the first's run, never doubles it.
        """
        key = (kind, recording.content_hash, recording.rig_hash, __version__)
        db.lock(_run_key(*key))
        db.execute(
            "INSERT INTO recordings (content_hash, path, start_ns, end_ns, duration_s) "
            "VALUES (?, ?, ?, ?, ?) ON CONFLICT (content_hash) DO UPDATE SET "
            "path = excluded.path, "
            "start_ns = coalesce(excluded.start_ns, recordings.start_ns), "
            "end_ns = coalesce(excluded.end_ns, recordings.end_ns), "
            "duration_s = coalesce(excluded.duration_s, recordings.duration_s)",
            (
                recording.content_hash,
                recording.path,
                recording.start_ns,
                recording.end_ns,
                recording.duration_s,
            ),
        )
        db.execute(
            "DELETE FROM runs WHERE kind = ? AND recording_hash = ? AND rig_hash = ? "
            "AND tool_version = ?",
            key,
        )
        return db.insert_returning_id(
            "INSERT INTO runs (kind, recording_hash, rig_name, rig_hash, rig_path, tool_version, "
            "written_at, status, error) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (
                kind,
                recording.content_hash,
                recording.rig_name,
                recording.rig_hash,
                recording.rig_path,
                __version__,
                datetime.now(UTC).isoformat(timespec="microseconds"),
                "ok" if error is None else "failed",
                error,
            ),
        )

    @staticmethod
    def _insert_metrics(
        db: Database, run: int, metrics: Mapping[str, Mapping[str, Mapping[str, float]]]
    ) -> None:
        db.executemany(
            "INSERT INTO metrics (run, model, channel, ptp_ratio_pct, tau_over_T_pct, nrmse) "
            "VALUES (?, ?, ?, ?, ?, ?)",
            [
                (run, model, channel, *(values[m] for m in SUMMARY_KEYS))
                for model, channels in metrics.items()
                for channel, values in channels.items()
            ],
        )

    # ------------------------------------------------------------------ reading

    def rigs(self) -> list[str]:
        """The names of the rigs with at least one stored diagnosis, sorted."""
        rows = self._connection.execute(
            "SELECT DISTINCT rig_name FROM runs WHERE kind = 'diagnosis' AND status = 'ok'"
        )
        return sorted(name for (name,) in rows)  # code points, as SQLite sorts (any collation)

    def diagnoses(self, rig: str | None = None, *, latest_only: bool = True) -> list[DiagnosisRow]:
        """The stored diagnoses (status ``ok``) in time order: recording start, then path.

        Args:
            rig: only those of this rig name (``None``: every rig).
            latest_only: one diagnosis per recording and rig file, the one written last (a
                recording diagnosed by two tool versions counts once).
        """
        query = (
            "SELECT r.id, c.path, c.content_hash, c.start_ns, c.end_ns, r.rig_name, r.rig_hash, "
            "r.rig_path, r.tool_version, r.written_at, r.effects, r.confidence, r.explanation "
            "FROM runs r JOIN recordings c ON c.content_hash = r.recording_hash "
            "WHERE r.kind = 'diagnosis' AND r.status = 'ok'"
            + (" AND r.rig_name = ?" if rig is not None else "")
            + " ORDER BY r.written_at, r.id"
        )
        runs = self._connection.execute(query, (rig,) if rig is not None else ()).fetchall()
        if latest_only:
            runs = list({(row[2], row[6]): row for row in runs}.values())
        runs.sort(key=lambda row: (row[3] is None, row[3] or 0, row[1], row[9]))
        return [self._diagnosis_row(row) for row in runs]

    def _diagnosis_row(self, row: Sequence[Any]) -> DiagnosisRow:
        run = int(row[0])
        db = self._connection
        calibration = tuple(
            CalibrationValue(name, multiplier, prior, posterior, improved)
            for name, multiplier, prior, posterior, improved in db.execute(
                "SELECT name, multiplier, prior_sigma, posterior_sigma, improved_multiplier "
                "FROM calibration WHERE run = ? ORDER BY {row_order}",
                (run,),
            )
        )
        hypotheses = tuple(
            HypothesisRow(effect, bool(named), improvement, score, json.loads(parameters))
            for effect, named, improvement, score, parameters in db.execute(
                "SELECT effect, named, held_out_improvement, score, parameters FROM effects "
                "WHERE run = ? ORDER BY {row_order}",
                (run,),
            )
        )
        metrics: dict[str, dict[str, dict[str, float]]] = {}
        for model, channel, *values in db.execute(
            "SELECT model, channel, ptp_ratio_pct, tau_over_T_pct, nrmse FROM metrics "
            "WHERE run = ? ORDER BY {row_order}",
            (run,),
        ):
            metrics.setdefault(model, {})[channel] = dict(zip(SUMMARY_KEYS, values))
        return DiagnosisRow(
            run_id=run,
            recording_path=row[1],
            recording_hash=row[2],
            start_ns=row[3],
            end_ns=row[4],
            rig_name=row[5],
            rig_hash=row[6],
            rig_path=row[7],
            tool_version=row[8],
            written_at=row[9],
            effects=tuple(json.loads(row[10])),
            confidence=float(row[11]),
            explanation=row[12],
            calibration=calibration,
            hypotheses=hypotheses,
            metrics=metrics,
        )

    def metrics(self, run_id: int) -> dict[str, dict[str, dict[str, float]]]:
        """The metrics of one run: model -> channel -> metric -> value ({} for a failure)."""
        result: dict[str, dict[str, dict[str, float]]] = {}
        for model, channel, *values in self._connection.execute(
            "SELECT model, channel, ptp_ratio_pct, tau_over_T_pct, nrmse FROM metrics "
            "WHERE run = ? ORDER BY {row_order}",
            (run_id,),
        ):
            result.setdefault(model, {})[channel] = dict(zip(SUMMARY_KEYS, values))
        return result

    def metrics_runs(self, rig: str | None = None) -> list[MetricsRun]:
        """The stored regressions and comparisons (status ``ok``), in the order they ran."""
        query = (
            "SELECT r.id, r.kind, c.path, c.content_hash, r.rig_name, r.rig_hash, "
            "r.tool_version, r.written_at FROM runs r "
            "JOIN recordings c ON c.content_hash = r.recording_hash "
            "WHERE r.kind IN ('regression', 'comparison') AND r.status = 'ok'"
            + (" AND r.rig_name = ?" if rig is not None else "")
            + " ORDER BY r.written_at, r.id"
        )
        rows = self._connection.execute(query, (rig,) if rig is not None else ()).fetchall()
        return [
            MetricsRun(
                run_id=int(row[0]),
                kind=row[1],
                recording_path=row[2],
                recording_hash=row[3],
                rig_name=row[4],
                rig_hash=row[5],
                tool_version=row[6],
                written_at=row[7],
                metrics=self.metrics(int(row[0])),
            )
            for row in rows
        ]

    def failures(self, rig: str | None = None) -> list[FailedRun]:
        """The failed runs (of one rig name, or every rig), in the order they were written."""
        query = (
            "SELECT r.id, r.kind, c.path, r.rig_name, r.tool_version, r.written_at, r.error "
            "FROM runs r JOIN recordings c ON c.content_hash = r.recording_hash "
            "WHERE r.status = 'failed'"
            + (" AND r.rig_name = ?" if rig is not None else "")
            + " ORDER BY r.written_at, r.id"
        )
        rows = self._connection.execute(query, (rig,) if rig is not None else ())
        return [FailedRun(*row) for row in rows]

    def counts(self) -> dict[str, int]:
        """Rows per table (recordings, runs, calibration, metrics, effects)."""
        return {
            table: int(self._connection.execute(f"SELECT count(*) FROM {table}").fetchone()[0])
            for table in TABLES[1:]
        }
