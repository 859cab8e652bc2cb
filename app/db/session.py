"""Engine and session factory for SQLite (embedded) and PostgreSQL (scale-out)."""

from __future__ import annotations

import hashlib
import json
import sqlite3
import threading
import time
from pathlib import Path
from typing import Any, cast

import psycopg
from pydantic_core import from_json
from sqlalchemy import CursorResult, Engine, Result, create_engine, event, func, select, update
from sqlalchemy.engine import URL, make_url
from sqlalchemy.orm import Session, sessionmaker

from app.db.migrate import WRITE_FIRST, upgrade
from app.db.models import FeedState

__all__ = [
    "make_engine", "make_session_factory", "migrated_engine", "one_at_a_time", "open_sessions",
    "json_loads", "pause_for_writers", "read_only", "rows_changed",
]


def make_engine(url: str) -> Engine:
    """Create the engine; on SQLite, make it safe for the API and worker threads to share."""
    parsed = make_url(url)
    if parsed.get_backend_name() != "sqlite":
        # As many pooled connections as the thread pool runs requests (anyio's default 40
        # threads; 16-64 concurrent searches): overflow connections are closed when given
        # back, so a pool smaller than the load would connect anew on most requests.
        return _postgres_engine(url, pool_pre_ping=True)

    if parsed.database and parsed.database != ":memory:":
        Path(parsed.database).parent.mkdir(parents=True, exist_ok=True)
    engine = create_engine(url, connect_args={"check_same_thread": False, "timeout": 30})

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_connection: Any, _record: Any) -> None:
        # Let SQLAlchemy, not the sqlite3 module, decide when transactions begin.
        dbapi_connection.isolation_level = None
        cursor = dbapi_connection.cursor()
        cursor.execute("PRAGMA busy_timeout=30000")
        _write_ahead_log(cursor)  # readers do not block the writer
        cursor.execute("PRAGMA foreign_keys=ON")
        cursor.close()

    @event.listens_for(engine, "begin")
    def _on_begin(connection: Any) -> None:
        # A deferred BEGIN: readers never wait (WAL). Write transactions therefore start
        # with their write (UPDATE/INSERT/DELETE ... RETURNING), which waits for the lock
        # (busy_timeout); one that read first and wrote later could fail with SQLITE_BUSY.
        # A connection that cannot start with its write (a migration: Alembic reads the
        # schema first) asks for the lock at BEGIN (``WRITE_FIRST``).
        immediate = connection.get_execution_options().get(WRITE_FIRST, False)
        connection.exec_driver_sql("BEGIN IMMEDIATE" if immediate else "BEGIN")

    return engine


def _write_ahead_log(cursor: sqlite3.Cursor, wait: float = 30.0) -> None:
    """Put the database in WAL mode, waiting up to ``wait`` seconds for the lock it needs.

    Turning a new file to WAL takes the database's exclusive lock, and SQLite answers a
    connection that finds it taken "database is locked" at once, busy timeout or not: of
    two processes opening a new file together (``serve`` and ``shapesearch worker``, or the
    compose file's services), one died at start in 2 of 6 trials
    (``tests/test_migrations.py``). So the statement is tried again until ``wait`` is over.
    """
    deadline = time.monotonic() + wait
    while True:
        try:
            cursor.execute("PRAGMA journal_mode=WAL")
            return
        except sqlite3.OperationalError as error:
            if "locked" not in str(error) or time.monotonic() > deadline:
                raise
            time.sleep(0.01)


def make_session_factory(engine: Engine) -> sessionmaker[Session]:
    return sessionmaker(engine, expire_on_commit=False)


def migrated_engine(url: str) -> Engine:
    """The engine of the database at ``url``, its schema first migrated to the latest
    revision (every process that opens the database does this: it is idempotent)."""
    engine = make_engine(url)
    upgrade(engine)
    return engine


def open_sessions(url: str) -> sessionmaker[Session]:
    """Sessions on the migrated database at ``url``: what a command or a worker needs."""
    return make_session_factory(migrated_engine(url))


def read_only(engine: Engine) -> Engine:
    """An engine for hot read-only request paths (similar, the model list); ``dispose`` it
    with ``engine``. Its connections run in autocommit: each statement is its own snapshot,
    and no ``BEGIN``/``ROLLBACK`` frames the request. A read path that needs one snapshot
    across statements must not use it.

    On PostgreSQL it has a pool of its own whose connections

    * are not pinged when checked out (a round trip per request, a fifth of a ``similar``'s
      cost): after a server restart the first request on a dead connection fails (503
      ``database-unavailable`` with Retry-After, ``app.db.errors``), and SQLAlchemy then
      invalidates the whole pool, so the next ones reconnect;
    * fetch results in PostgreSQL's binary format: descriptors (6 KB each, a few dozen per
      query) arrive as bytes instead of hex text to decode, half the cost of the fetch.

    On SQLite (a database file) its connections are the driver's own autocommit ones, refuse
    to write (``PRAGMA query_only``), read the file through a memory map (rows whose size
    columns lie past a model's blobs walk their overflow pages in memory instead of through
    a page cache of 2 MB per connection: a similar's candidates read 3x faster at 40
    models) and decode JSON columns with ``json_loads``; an in-memory database is the engine
    itself.
    """
    if engine.dialect.name == "postgresql":
        return _postgres_engine(
            engine.url,
            isolation_level="AUTOCOMMIT",
            connect_args={"cursor_factory": _BinaryCursor},
        )
    database = engine.url.database
    if not database or database == ":memory:" or "memory" in str(engine.url.query.get("mode")):
        return engine
    reader = create_engine(
        engine.url, connect_args={"check_same_thread": False, "timeout": 30},
        isolation_level="AUTOCOMMIT", json_deserializer=json_loads,
    )

    @event.listens_for(reader, "connect")
    def _on_connect(dbapi_connection: Any, _record: Any) -> None:
        cursor = dbapi_connection.cursor()
        cursor.execute("PRAGMA busy_timeout=30000")
        cursor.execute("PRAGMA query_only=ON")
        cursor.execute("PRAGMA mmap_size=268435456")
        cursor.close()

    return reader


def json_loads(text: str | bytes) -> Any:
    """``json.loads``, three times faster: pydantic-core's parser, which reads every JSON
    text as ``json.loads`` does (big integers, NaN, duplicate keys: the last) except a lone
    surrogate escape, which it refuses: that text is left to ``json.loads``."""
    try:
        return from_json(text)
    except ValueError:
        return json.loads(text)


class _BinaryCursor(psycopg.Cursor[Any]):
    """A psycopg cursor that asks for binary results unless told otherwise."""

    def execute(
        self,
        query: Any,
        params: Any = None,
        *,
        prepare: bool | None = None,
        binary: bool | None = None,
    ) -> _BinaryCursor:
        return super().execute(
            query, params, prepare=prepare, binary=True if binary is None else binary
        )


def _postgres_engine(url: str | URL, **options: Any) -> Engine:
    engine = create_engine(url, pool_size=20, max_overflow=30, **options)

    @event.listens_for(engine, "connect")
    def _custom_plans(dbapi_connection: Any, _record: Any) -> None:
        # psycopg prepares a statement run five times; PostgreSQL may then switch to a
        # generic plan, which for the metadata filter (jsonb @> a parameter) is a scan of
        # the whole table (100+ ms at 10^5 models) instead of the GIN index (5 ms).
        # Custom plans keep prepared statements' parse savings and plan with the values.
        dbapi_connection.execute("SET plan_cache_mode = force_custom_plan")
        dbapi_connection.commit()

    return engine


def rows_changed(result: Result[Any]) -> int:
    """How many rows an UPDATE or DELETE changed: its cursor's ``rowcount`` (SQLAlchemy
    types ``Session.execute``'s result without it)."""
    return int(cast(CursorResult[Any], result).rowcount or 0)


def one_at_a_time(session: Session, name: str) -> None:
    """Make ``session``'s transaction the only one past this call for ``name`` in every
    process, until it ends; call it first in the transaction.

    PostgreSQL: a transaction-level advisory lock keyed by ``name``; statements after it see
    every commit made before it was granted (READ COMMITTED), so a claim that reads and then
    writes cannot act on a read that another claim's commit made stale. SQLite: the
    database's write lock, taken by a write that changes nothing. SQLite has one writer, and
    a transaction that read first cannot take the lock once another connection committed
    meanwhile: its write fails at once with "database is locked", busy timeout or not.
    """
    if session.get_bind().dialect.name == "postgresql":
        key = int.from_bytes(hashlib.sha256(name.encode()).digest()[:8], "big", signed=True)
        session.execute(select(func.pg_advisory_xact_lock(key)))
    else:
        session.execute(update(FeedState).where(FeedState.id == 0).values(revision=0))


def pause_for_writers(started: float, stop: threading.Event | None = None) -> None:
    """Wait after one transaction of a long series of writes that began at ``started``
    (``time.monotonic()``): as long as it took, and at least SQLite's longest busy-handler
    sleep (100 ms), so that other writers take the lock between two of them. Back to back,
    the history pruner's batches kept an upload waiting up to 835 ms, since a waiter
    retries only between its sleeps (``bench/history_retention.py``). ``stop`` set: at once.
    """
    (stop or threading.Event()).wait(max(time.monotonic() - started, 0.1))
