"""A database that is away for a moment (a PostgreSQL restart, a fail-over, a locked SQLite
file) is 503 ``database-unavailable`` with Retry-After, which clients retry, not a 500; the
next request finds it again.

The outage is a real one: the server ends every connection of the test's database
(``pg_terminate_backend``, what a restart does to them)."""

from __future__ import annotations

import sqlite3
from collections.abc import Callable
from pathlib import Path

import psycopg
import pytest
from fastapi.testclient import TestClient
from sqlalchemy.engine import make_url

from app.api.main import create_app
from app.db.errors import database_unavailable
from app.storage import storage_full
from tests.conftest import PARTS, fake_describe, make_settings, upload, wait_for_status


def end_every_connection(url: str) -> int:
    """End every server connection to the database at ``url``, as a restart would."""
    parsed = make_url(url)
    with psycopg.connect(
        host=parsed.host, port=parsed.port, user=parsed.username, dbname="postgres",
        autocommit=True,
    ) as admin:
        row = admin.execute(
            "SELECT count(pg_terminate_backend(pid)) FROM pg_stat_activity "
            "WHERE datname = %s AND pid <> pg_backend_pid()", (parsed.database,)
        ).fetchone()
    return int(row[0]) if row else 0


def locked_database_error(folder: Path) -> sqlite3.OperationalError:
    """SQLite's "database is locked": another connection holds the write lock."""
    holder = sqlite3.connect(folder / "locked.db", isolation_level=None)
    holder.execute("CREATE TABLE t (x)")
    holder.execute("BEGIN IMMEDIATE")
    waiter = sqlite3.connect(folder / "locked.db", timeout=0, isolation_level=None)
    try:
        with pytest.raises(sqlite3.OperationalError) as locked:
            waiter.execute("BEGIN IMMEDIATE")
    finally:
        holder.close()
        waiter.close()
    assert "locked" in str(locked.value)
    return locked.value


@pytest.mark.slow
def test_a_read_after_a_database_restart_is_answered_on_a_new_connection(
    new_database_url: Callable[[str], str],
) -> None:
    url = new_database_url("postgresql")
    app = create_app(make_settings(url), embedded_worker=True, job_handler=fake_describe)
    with TestClient(app, raise_server_exceptions=False) as client:
        first = upload(client, PARTS / "20mm-xyz-cube.stl").json()["id"]
        wait_for_status(client, upload(client, PARTS / "cylinder.stl").json()["id"])
        wait_for_status(client, first)
        answer = client.get(f"/v1/models/{first}/similar").json()
        assert answer["results"]

        assert end_every_connection(url) > 0
        # The read path's pooled connections are not pinged (a round trip per request):
        # the first try on a dead one learns of the restart, and the pool is dropped. The
        # hot path (app.api.hot_reads) hands a failed try to the route, which runs on a new
        # connection: the client sees an answer, not the restart.
        # (Each request asks for another k: the response cache must not answer it.)
        after = client.get(f"/v1/models/{first}/similar", params={"k": 3})
        assert after.status_code == 200, after.text
        assert after.json()["results"] == answer["results"]
        # Writes go through pinged connections: they never saw the restart.
        assert upload(client, PARTS / "angle_block.STL").status_code == 202


def test_database_unavailable_is_told_from_other_database_errors(
    tmp_path: Path, new_database_url: Callable[[str], str],
) -> None:
    with pytest.raises(psycopg.OperationalError) as refused:  # nothing listens on port 1
        psycopg.connect(host="127.0.0.1", port=1, connect_timeout=5)
    assert database_unavailable(refused.value)

    url = make_url(new_database_url("postgresql"))
    with (
        psycopg.connect(host=url.host, port=url.port, user=url.username,
                        dbname=url.database) as connection,
        pytest.raises(psycopg.errors.QueryCanceled) as timed_out,
    ):
        connection.execute("SET statement_timeout = 10")
        connection.execute("SELECT pg_sleep(1)")
    # A statement that ran too long is an OperationalError too, but the database was there.
    assert isinstance(timed_out.value, psycopg.OperationalError)
    assert not database_unavailable(timed_out.value)

    locked = locked_database_error(tmp_path)
    assert database_unavailable(locked) and not storage_full(locked)
    with pytest.raises(sqlite3.OperationalError) as bad_sql:
        sqlite3.connect(":memory:").execute("SELECT * FROM no_such_table")
    assert not database_unavailable(bad_sql.value)
    assert not database_unavailable(ValueError("a bug"))
