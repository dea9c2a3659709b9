"""A private PostgreSQL server for the results database's tests: one per test session.

``pgserver`` (a ``dev`` extra) bundles PostgreSQL's binaries. It starts the server on a Unix
socket in a new temporary folder with no TCP address at all (``listen_addresses`` empty, so
nothing leaves the machine) and trust authentication. PostgreSQL refuses to run as root: run
as root, pgserver adds a system user ``pgserver`` (``useradd``, once) and runs ``initdb`` and
``pg_ctl`` as that user, making the folders above the data folder and its own binaries
readable by others. Each test gets a database of its own on the one server.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
import itertools
import os
from pathlib import Path
import shutil
import tempfile
import warnings

import pytest

_DATABASE_NUMBERS = itertools.count()


@dataclass(frozen=True)
class PostgresServer:
    """The session's server: its socket folder and the URLs of its databases."""

    socket_dir: Path

    def url(self, database: str = "postgres", user: str = "postgres") -> str:
        """libpq's URL of one database over the socket."""
        return f"postgresql://{user}@/{database}?host={self.socket_dir}"

    def admin(self, statement: str) -> list[tuple[object, ...]]:
        """Run one statement as the superuser in the ``postgres`` database; its rows."""
        import psycopg

        with psycopg.connect(self.url(), autocommit=True) as connection:
            cursor = connection.execute(statement)
            return cursor.fetchall() if cursor.description is not None else []


@pytest.fixture(scope="session")
def postgres_server() -> Iterator[PostgresServer]:
    """Start the server for the session; stop it after.

    On a developer's machine a server that cannot start skips the PostgreSQL tests with the
    reason; in CI (``CI=true``, where the README's setup installed pgserver) it fails them.
    """
    in_ci = os.environ.get("CI", "").lower() == "true"
    try:
        with warnings.catch_warnings():  # platformdirs: no XDG_RUNTIME_DIR, /tmp used instead
            warnings.simplefilter("ignore")
            import pgserver
    except ImportError as err:
        if in_ci:
            raise
        pytest.skip(f"no PostgreSQL server for the tests: pgserver is not installed ({err})")
    root = Path(tempfile.mkdtemp(prefix="brake_hil_pg_"))
    try:
        server = pgserver.get_server(root / "pgdata", cleanup_mode="delete")
    except Exception as err:  # pgserver raises what initdb, pg_ctl or useradd raised
        shutil.rmtree(root, ignore_errors=True)
        if in_ci:
            raise
        pytest.skip(f"the test PostgreSQL server did not start: {type(err).__name__}: {err}")
    try:
        socket_dir = server.get_postmaster_info().socket_dir
        assert socket_dir is not None, "pgserver started a server without a Unix socket"
        started = PostgresServer(Path(socket_dir))
        assert started.admin("SHOW listen_addresses") == [("",)], "listening on TCP"
        yield started
    finally:
        server.cleanup()
        shutil.rmtree(root, ignore_errors=True)


@pytest.fixture
def postgres_url(postgres_server: PostgresServer) -> Iterator[str]:
    """A new, empty database on the session's server (dropped after the test)."""
    name = f"results_{next(_DATABASE_NUMBERS)}"
    postgres_server.admin(f"CREATE DATABASE {name}")
    yield postgres_server.url(name)
    postgres_server.admin(f"DROP DATABASE {name} WITH (FORCE)")
