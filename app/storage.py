"""Storage full: the one failure that no client caused and no quick retry mends.

A full disk shows itself in three ways: SQLite's ``SQLITE_FULL`` ("database or disk is
full"), PostgreSQL's ``disk_full`` (SQLSTATE 53100) and an ``OSError`` ``ENOSPC`` or
``EDQUOT`` from a temporary file (a spooled upload, a CAD or E57 reader's copy of it).
``storage_full`` recognises each however deeply SQLAlchemy, FastAPI or the sandbox wrapped
it, so that the API answers 507 ``storage-full`` (nothing was stored, nothing was wrong
with the request) and a worker puts its job back without spending an attempt, instead of
a 500, a job failed after its retries, or a valid file refused as unparsable.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator

from psycopg.errors import DiskFull

from core.errors import NO_SPACE_ERRNOS

__all__ = ["storage_full"]

_SQLITE_FULL = 13  # the primary result code; extended codes keep it in their low byte


def storage_full(error: BaseException) -> bool:
    """Whether ``error``, or any exception it wraps, says that storage is full."""
    return any(_says_full(each) for each in _chain(error))


def _says_full(error: BaseException) -> bool:
    if isinstance(error, sqlite3.Error):
        code = getattr(error, "sqlite_errorcode", None)
        return code is not None and code & 0xFF == _SQLITE_FULL
    if isinstance(error, DiskFull):
        return True
    return isinstance(error, OSError) and error.errno in NO_SPACE_ERRNOS


def _chain(error: BaseException) -> Iterator[BaseException]:
    """``error``, the driver's exception under SQLAlchemy's (``orig``) and every explicit
    cause (``raise ... from``), each once. Not the implicit context: an unrelated error
    raised while a full disk was being handled is not itself a full disk."""
    pending: list[BaseException] = [error]
    seen: set[int] = set()
    while pending:
        current = pending.pop()
        if id(current) in seen:
            continue
        seen.add(id(current))
        yield current
        for wrapped in (getattr(current, "orig", None), current.__cause__):
            if isinstance(wrapped, BaseException):
                pending.append(wrapped)
