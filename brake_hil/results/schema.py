"""The results database's schema: its tables, and the check that a database is ours.

:func:`prepare` makes the tables of a new database (in one transaction, another process
may be making them too) and refuses a database of another application or of another
schema version.
"""

from __future__ import annotations

from typing import Final

from brake_hil.errors import BrakeHilError
from brake_hil.results.backends import Database, enforce_foreign_keys, set_wal

__all__ = [
    "APPLICATION",
    "KINDS",
    "SCHEMA_TEXT",
    "SCHEMA_VERSION",
    "TABLES",
    "one_line",
    "prepare",
]

APPLICATION: Final = "brake_hil results"
"""``meta.application`` of a results database: a file without it is not ours."""
SCHEMA_VERSION: Final = 1
"""``meta.schema_version`` this module writes and reads."""
KINDS: Final = ("diagnosis", "regression", "comparison")
"""The commands whose results are stored."""

SCHEMA_TEXT: Final = """
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
"""The tables, their column types in braces filled by the backend's dialect."""
TABLES: Final = ("meta", "recordings", "runs", "calibration", "metrics", "effects")
"""Every table of the schema, ``meta`` first."""


def prepare(database: Database, create: bool) -> None:
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
            f"{database.name}: not a usable results database: {one_line(str(err))}"
        ) from err


def _create_schema(database: Database) -> None:
    """The tables and ``meta``, in one transaction (another process may be making them too)."""
    with database.transaction() as db:
        db.lock(APPLICATION)
        for statement in db.dialect.schema(SCHEMA_TEXT):
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
    if missing := [t for t in TABLES if t not in tables]:
        raise BrakeHilError(f"{name}: results database without table {', '.join(missing)}")


def one_line(text: str) -> str:
    """``text`` on one line (its whitespace runs made one space)."""
    return " ".join(text.split()) or "(no message)"
