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
* ``metrics``: the seed's Table 4-5 metrics per model (``baseline``, ``improved``,
  ``model``) and channel;
* ``effects``: a diagnosis's hypotheses: held-out improvement, score, whether the verdict
  names them, fitted parameters (JSON).

A run is written in one transaction after its document was checked, so a refused document or
an error mid-write leaves nothing of it; a failed command is kept as ``failed``, never with
metrics. Several processes may append at once: an SQLite file is in WAL mode and a writer
waits up to :data:`BUSY_TIMEOUT_S` for another's transaction; on PostgreSQL two writers of
the same run key take turns on the key's advisory lock, others write side by side. A
database that is not ours (no ``meta`` of this application) or of a newer schema is refused.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
import json
import math
from pathlib import Path
from types import TracebackType
from typing import Any, Final

from brake_hil import __version__
from brake_hil.analysis.comparison import SUMMARY_KEYS
from brake_hil.errors import BrakeHilError
from brake_hil.results.backends import (
    BUSY_TIMEOUT_S,
    Database,
    database_path,
    enforce_foreign_keys,
    open_database,
    set_wal,
)
from brake_hil.results.identity import RecordingIdentity, identify_loosely

__all__ = [
    "APPLICATION",
    "BUSY_TIMEOUT_S",
    "KINDS",
    "SCHEMA_VERSION",
    "CalibrationValue",
    "DiagnosisRow",
    "FailedRun",
    "HypothesisRow",
    "ResultsStore",
    "database_path",
    "open_store",
]

APPLICATION: Final = "brake_hil results"
"""``meta.application`` of a results database: a file without it is not ours."""
SCHEMA_VERSION: Final = 1
"""``meta.schema_version`` this module writes and reads."""
KINDS: Final = ("diagnosis", "regression", "comparison")
"""The commands whose results are stored."""

_SCHEMA: Final = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS recordings (
    content_hash TEXT PRIMARY KEY,
    path TEXT NOT NULL,
    start_ns {int64},
    end_ns {int64},
    duration_s {real}
);
CREATE TABLE IF NOT EXISTS runs (
    id {id},
    kind TEXT NOT NULL CHECK (kind IN ('diagnosis', 'regression', 'comparison')),
    recording_hash TEXT NOT NULL REFERENCES recordings (content_hash),
    rig_name TEXT NOT NULL,
    rig_hash TEXT NOT NULL,
    rig_path TEXT NOT NULL,
    tool_version TEXT NOT NULL,
    written_at TEXT NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('ok', 'failed')),
    error TEXT,
    effects TEXT,
    confidence {real},
    explanation TEXT,
    UNIQUE (kind, recording_hash, rig_hash, tool_version)
);
CREATE INDEX IF NOT EXISTS runs_by_rig ON runs (kind, rig_name);
CREATE TABLE IF NOT EXISTS calibration (
    {seq}
    run {int64} NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
    name TEXT NOT NULL,
    multiplier {real} NOT NULL,
    prior_sigma {real} NOT NULL,
    posterior_sigma {real} NOT NULL,
    improved_multiplier {real},
    PRIMARY KEY (run, name)
);
CREATE TABLE IF NOT EXISTS metrics (
    {seq}
    run {int64} NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
    model TEXT NOT NULL,
    channel TEXT NOT NULL,
    ptp_ratio_pct {real} NOT NULL,
    tau_over_T_pct {real} NOT NULL,
    nrmse {real} NOT NULL,
    PRIMARY KEY (run, model, channel)
);
CREATE TABLE IF NOT EXISTS effects (
    {seq}
    run {int64} NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
    effect TEXT NOT NULL,
    named INTEGER NOT NULL CHECK (named IN (0, 1)),
    held_out_improvement {real} NOT NULL,
    score {real} NOT NULL,
    parameters TEXT NOT NULL,
    PRIMARY KEY (run, effect)
);
"""
_DIAGNOSIS_MODELS: Final = ("baseline", "improved")
_TABLES: Final = ("meta", "recordings", "runs", "calibration", "metrics", "effects")

Metrics = Mapping[str, Mapping[str, Mapping[str, float]]]
"""Model name -> channel -> metric -> value (the seed's Table 4-5 metrics)."""


@dataclass(frozen=True)
class CalibrationValue:
    """One calibrated rig value of a diagnosis."""

    name: str  # e.g. caliper_stiffness
    multiplier: float  # calibrated LTI model's value over the rig file's (1 = nominal)
    prior_sigma: float  # the rig file's tolerance (log-sigma)
    posterior_sigma: float  # after the data (log-sigma; inf: not identified at all)
    improved_multiplier: float | None  # the improved model's value over the rig file's


@dataclass(frozen=True)
class HypothesisRow:
    """One hypothesis a diagnosis fitted: an effect or a pair (``a+b``)."""

    effect: str
    named: bool  # every effect of it is in the verdict
    held_out_improvement: float  # held-out mean squared error, baseline over hypothesis
    score: float  # log improvement less a charge per parameter
    parameters: Mapping[str, float]  # fitted, SI units


@dataclass(frozen=True)
class DiagnosisRow:
    """One stored diagnosis: the recording, the rig file, the verdict and its numbers."""

    run_id: int
    recording_path: str
    recording_hash: str
    start_ns: int | None  # first log time (ns since the epoch)
    end_ns: int | None  # last log time (ns since the epoch)
    rig_name: str
    rig_hash: str
    rig_path: str
    tool_version: str
    written_at: str  # ISO 8601, UTC
    effects: tuple[str, ...]  # the verdict
    confidence: float  # 0-1
    explanation: str
    calibration: tuple[CalibrationValue, ...]
    hypotheses: tuple[HypothesisRow, ...]
    metrics: Metrics  # model (baseline, improved) -> channel -> metric -> value


@dataclass(frozen=True)
class FailedRun:
    """A command that failed on a recording: stored so, never as a result."""

    run_id: int
    kind: str
    recording_path: str
    rig_name: str
    tool_version: str
    written_at: str  # ISO 8601, UTC
    error: str  # its one line


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
        _prepare(database, create)
    except BaseException:
        database.close()
        raise
    return ResultsStore(database)


def _prepare(database: Database, create: bool) -> None:
    """Check the database is a results database of this schema (make it so when new)."""
    try:
        tables = database.tables()
        if not tables:
            if not create:
                raise BrakeHilError(f"{database.name}: an empty database, no results in it")
            set_wal(database)
            _create_schema(database)
            tables = database.tables()
        _check_ours(database, tables)
        enforce_foreign_keys(database)
    except database.errors as err:
        raise BrakeHilError(
            f"{database.name}: not a usable results database: {_one_line(str(err))}"
        ) from err


def _create_schema(database: Database) -> None:
    """The tables and ``meta``, in one transaction (another process may be making them too)."""
    with database.transaction() as db:
        db.lock(APPLICATION)
        for statement in db.dialect.schema(_SCHEMA):
            db.execute(statement)
        db.execute(
            "INSERT INTO meta (key, value) VALUES (?, ?), (?, ?) ON CONFLICT DO NOTHING",
            ("application", APPLICATION, "schema_version", str(SCHEMA_VERSION)),
        )


def _check_ours(database: Database, tables: set[str]) -> None:
    name = database.name
    if "meta" not in tables:
        shown = ", ".join(sorted(tables))
        raise BrakeHilError(f"{name}: not a brake_hil results database (its tables: {shown})")
    meta = {str(key): value for key, value in database.execute("SELECT key, value FROM meta")}
    if meta.get("application") != APPLICATION:
        raise BrakeHilError(f"{name}: not a brake_hil results database (a meta table of another)")
    version = str(meta.get("schema_version", ""))
    if version != str(SCHEMA_VERSION):
        newer = version.isdigit() and int(version) > SCHEMA_VERSION
        raise BrakeHilError(
            f"{name}: results schema {version or '?'}, this brake_hil reads {SCHEMA_VERSION}"
            + (" (written by a newer brake_hil)" if newer else "")
        )
    if missing := [t for t in _TABLES if t not in tables]:
        raise BrakeHilError(f"{name}: results database without table {', '.join(missing)}")


# --------------------------------------------------------------------------- checks


class _KeyRefusedError(BrakeHilError, ValueError):
    """A key of a document is missing or its value refused (the caller names the document)."""

    def __init__(self, key: str, problem: str) -> None:
        super().__init__(f"{key}: {problem}")


def _refuse(key: str, problem: str) -> _KeyRefusedError:
    return _KeyRefusedError(key, problem)


def _mapping(value: object, key: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
        raise _refuse(key, "missing or not a mapping")
    return value


def _number(value: object, key: str, *, positive: bool = False, infinite: bool = False) -> float:
    """A finite float (or +inf with ``infinite``), above 0 with ``positive``."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _refuse(key, f"missing or not a number ({value!r})")
    try:
        number = float(value)
    except OverflowError:
        raise _refuse(key, "not a finite number (too large)") from None
    if math.isnan(number) or (math.isinf(number) and not (infinite and number > 0)):
        raise _refuse(key, f"not a finite number ({number})")
    if positive and number <= 0:
        raise _refuse(key, f"must be above 0 ({number})")
    return number


def _numbers(value: object, key: str) -> dict[str, float]:
    return {name: _number(v, f"{key}.{name}") for name, v in _mapping(value, key).items()}


def check_metrics(metrics: object, key: str = "metrics") -> dict[str, dict[str, float]]:
    """Channel -> the seed's three metrics (finite); other metrics are not kept.

    Raises:
        BrakeHilError: a channel without one of them, or a value not finite (the message
            starts with the key, e.g. ``metrics.F_k.nrmse``).
    """
    channels = _mapping(metrics, key)
    if not channels:
        raise _refuse(key, "no channel")
    checked: dict[str, dict[str, float]] = {}
    for channel, values in channels.items():
        row = _mapping(values, f"{key}.{channel}")
        checked[channel] = {m: _number(row.get(m), f"{key}.{channel}.{m}") for m in SUMMARY_KEYS}
    return checked


@dataclass(frozen=True)
class _Diagnosis:
    """What a diagnosis document holds that the store keeps, checked."""

    effects: tuple[str, ...]
    confidence: float
    explanation: str
    calibration: tuple[CalibrationValue, ...]
    hypotheses: tuple[HypothesisRow, ...]
    metrics: dict[str, dict[str, dict[str, float]]]


def check_diagnosis(document: Mapping[str, Any]) -> _Diagnosis:
    """The stored parts of a ``diagnosis.json`` document, each checked.

    Raises:
        BrakeHilError: a missing key or a value of the wrong type, not finite (a confidence
            outside 0-1, a multiplier or improvement not above 0); the message starts with
            the key (e.g. ``verdict.confidence``).
    """
    top = _mapping(document, "document")
    verdict = _mapping(top.get("verdict"), "verdict")
    effects = verdict.get("effects")
    if not isinstance(effects, list | tuple) or not all(isinstance(e, str) for e in effects):
        raise _refuse("verdict.effects", "missing or not a list of effect names")
    confidence = _number(verdict.get("confidence"), "verdict.confidence")
    if not 0.0 <= confidence <= 1.0:
        raise _refuse("verdict.confidence", f"outside 0-1 ({confidence})")
    explanation = verdict.get("explanation")
    if not isinstance(explanation, str):
        raise _refuse("verdict.explanation", "missing or not text")
    return _Diagnosis(
        effects=tuple(effects),
        confidence=confidence,
        explanation=explanation,
        calibration=_calibration(top),
        hypotheses=_hypotheses(top.get("hypotheses"), set(effects)),
        metrics={model: _model_metrics(top, model) for model in _DIAGNOSIS_MODELS},
    )


def _model_metrics(top: Mapping[str, Any], model: str) -> dict[str, dict[str, float]]:
    return check_metrics(_mapping(top.get(model), model).get("metrics"), f"{model}.metrics")


def _calibration(top: Mapping[str, Any]) -> tuple[CalibrationValue, ...]:
    calibration = _mapping(top.get("calibration"), "calibration")
    multipliers = _mapping(calibration.get("multipliers"), "calibration.multipliers")
    prior = _mapping(calibration.get("prior_sigma"), "calibration.prior_sigma")
    posterior = _mapping(calibration.get("posterior_sigma"), "calibration.posterior_sigma")
    improved = _mapping(top.get("improved"), "improved")
    parameters = _numbers(improved.get("parameters", {}), "improved.parameters")
    values = []
    for name, multiplier in multipliers.items():
        sigma = _number(prior.get(name), f"calibration.prior_sigma.{name}", positive=True)
        after = _number(posterior.get(name), f"calibration.posterior_sigma.{name}", infinite=True)
        if after < 0:
            raise _refuse(f"calibration.posterior_sigma.{name}", f"below 0 ({after})")
        refit = parameters.get(f"calibration.{name}")
        if refit is not None and refit <= 0:
            raise _refuse(f"improved.parameters.calibration.{name}", f"not above 0 ({refit})")
        values.append(
            CalibrationValue(
                name=name,
                multiplier=_number(multiplier, f"calibration.multipliers.{name}", positive=True),
                prior_sigma=sigma,
                posterior_sigma=after,
                improved_multiplier=refit,
            )
        )
    return tuple(values)


def _hypotheses(raw: object, named: set[str]) -> tuple[HypothesisRow, ...]:
    if not isinstance(raw, list | tuple):
        raise _refuse("hypotheses", "missing or not a list")
    rows: dict[str, HypothesisRow] = {}
    for index, item in enumerate(raw):
        key = f"hypotheses[{index}]"
        entry = _mapping(item, key)
        effect = entry.get("effect")
        if not isinstance(effect, str) or not effect:
            raise _refuse(f"{key}.effect", "missing or not an effect name")
        if effect in rows:
            raise _refuse(f"{key}.effect", f"{effect} twice")
        rows[effect] = HypothesisRow(
            effect=effect,
            named=bool(named) and set(effect.split("+")) <= named,
            held_out_improvement=_number(
                entry.get("held_out_improvement"), f"{key}.held_out_improvement", positive=True
            ),
            score=_number(entry.get("score"), f"{key}.score"),
            parameters=_numbers(entry.get("parameters", {}), f"{key}.parameters"),
        )
    return tuple(rows.values())


def _run_key(kind: str, recording_hash: str, rig_hash: str, version: str) -> str:
    """A run's key as one text: what a writer locks on PostgreSQL."""
    return "\x1f".join(("brake_hil run", kind, recording_hash, rig_hash, version))


def _one_line(text: str) -> str:
    return " ".join(text.split()) or "(no message)"


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
        except _KeyRefusedError as err:
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
            models = _mapping(metrics, "metrics")
            if not models:
                raise _refuse("metrics", "no model")
            checked = {model: check_metrics(v, f"metrics.{model}") for model, v in models.items()}
        except _KeyRefusedError as err:
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
            run = self._new_run(db, kind, recording, error=_one_line(error))
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
            for table in _TABLES[1:]
        }
