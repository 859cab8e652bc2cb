"""What a database error means for a request: the database unavailable for a moment.

``database_unavailable(error)`` is true when the connection was lost (a PostgreSQL restart
or fail-over ended it; SQLAlchemy then invalidates the pool, which reconnects on the next
use), when the server could not be reached at all (refused, timed out, "the database system
is starting up"), or when SQLite stayed locked past its busy timeout. The API answers those
503 ``database-unavailable`` with a short Retry-After, which clients retry, instead of a
500 that reads like a bug. Full storage is told apart by ``app.storage``.
"""

from __future__ import annotations

import sqlite3

import psycopg
from sqlalchemy.exc import DBAPIError

__all__ = ["database_unavailable"]

# SQLSTATE class 08 (connection exception); admin shutdown, crash shutdown, cannot connect now.
_UNAVAILABLE_STATES = ("08", "57P01", "57P02", "57P03")
# SQLITE_BUSY, SQLITE_LOCKED, SQLITE_CANTOPEN (primary result codes).
_SQLITE_UNAVAILABLE = frozenset({5, 6, 14})


def database_unavailable(error: BaseException) -> bool:
    """Whether ``error`` says the database could not be used just now (see the module)."""
    if isinstance(error, DBAPIError) and error.connection_invalidated:
        return True
    driver_error = error.orig if isinstance(error, DBAPIError) else error
    if isinstance(driver_error, psycopg.OperationalError):
        # No SQLSTATE: the client library's own failure to connect or to talk to the server.
        state = driver_error.sqlstate
        return state is None or state.startswith(_UNAVAILABLE_STATES)
    if isinstance(driver_error, sqlite3.OperationalError):
        code = getattr(driver_error, "sqlite_errorcode", None)
        return code is not None and code & 0xFF in _SQLITE_UNAVAILABLE
    return False
