"""The results database's door for the commands: what each appends, in one place.

``diagnose`` appends every diagnosis (default database: ``results.sqlite`` in its output
folder); ``compare`` and ``regress`` append their metrics when ``--db`` is given (a file,
``sqlite:///PATH`` or ``postgresql://...``). Each recording is one transaction
(:mod:`brake_hil.results.store`); each function returns the database's name (its file, or
its URL with the password masked).
"""

from __future__ import annotations

from collections.abc import Mapping
import json
from pathlib import Path

from brake_hil.errors import BrakeHilError
from brake_hil.files import check_output_file
from brake_hil.results.backends import database_path
from brake_hil.results.identity import identify, identify_with_model
from brake_hil.results.store import open_store

__all__ = [
    "DATABASE_NAME",
    "append_comparison",
    "append_diagnosis",
    "append_regression",
    "check_database",
    "database_folder",
]

DATABASE_NAME = "results.sqlite"
"""The results database's file name in an output folder, when ``--db`` is not given."""

ChannelMetrics = Mapping[str, Mapping[str, float]]
"""Channel -> metric -> value."""


def _opened(database: Path | str) -> Path | str:
    """A database path checked through the output door (its folder made, writable)."""
    if isinstance(database, Path):
        check_output_file(database)
    return database


def database_folder(database: Path | str | None) -> Path | None:
    """The folder of a database file (``None``: no database, or a server's)."""
    if database is None:
        return None
    try:
        return database_path(database).parent
    except BrakeHilError:
        return None


def check_database(database: Path | str | None) -> None:
    """Open the database before the work: a bad one is refused first.

    A database file that does not exist yet is not made here (only its folder, proved
    writable): a command refused later leaves no empty database behind; the first append
    makes it.

    Raises:
        BrakeHilError: a URL of another scheme, a file or server database that is not a
            results database, a server not reached, or a path that cannot be written (one
            line naming it).
    """
    if database is None:
        return
    file = database_folder(database) and database_path(database)
    if file is not None:
        check_output_file(file)
        if not file.exists():
            return
    with open_store(_opened(database)):
        pass


def append_diagnosis(recording: Path, rig: Path, json_path: Path, database: Path | str) -> str:
    """Append one ``diagnosis.json`` to the database."""
    document = json.loads(json_path.read_text(encoding="utf-8"))
    with open_store(_opened(database)) as store:
        store.record_diagnosis(identify(recording, rig), document)
        return store.name


def append_comparison(
    recording: Path, rig: Path, metrics: ChannelMetrics, database: Path | str
) -> str:
    """Append ``compare``'s metrics (the rig file's LTI model) to the database."""
    with open_store(_opened(database)) as store:
        store.record_metrics("comparison", identify(recording, rig), {"model": metrics})
        return store.name


def append_regression(
    replays: Mapping[Path, ChannelMetrics], model_file: Path, database: Path | str
) -> str:
    """Append each replayed recording's metrics (``regress``), one transaction each."""
    with open_store(_opened(database)) as store:
        for recording, metrics in replays.items():
            identity = identify_with_model(recording, model_file)
            store.record_metrics("regression", identity, {"model": metrics})
        return store.name
