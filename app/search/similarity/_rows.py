"""What the database confirms of a candidate, and what an answer shows of it.

Every candidate the index finds is confirmed by the database, the source of truth, in one
statement of the few columns an answer shows (``ready_candidates``): a model deleted by
another process a moment ago is never returned.
"""

from __future__ import annotations

import collections
import functools
import sqlite3
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from sqlalchemy import Connection, Row
from sqlalchemy.exc import DBAPIError

from app.db.models import Model
from app.db.session import json_loads
from app.search.index import PartitionKey
from core.size import SIZE_FIELDS, ShapeSize


@dataclass(frozen=True)
class Candidate:
    """What an answer shows of a matching model (the fields of ``ModelSummary``); ``size``
    in the file's ``units`` (None: described before sizes were stored)."""

    index_id: int
    id: uuid.UUID
    external_id: str | None
    name: str | None
    meta: dict[str, Any] | None
    size: ShapeSize | None = None
    units: str | None = None


@dataclass(frozen=True)
class Match:
    """One result; ``view`` is the view that matched best in scan mode (None: the whole
    model, and always in shape mode)."""

    model: Candidate
    distance: float
    score: float
    view: int | None = None


def score_of(distance: float) -> float:
    """``1 - d^2 / 4`` of an L2 distance between unit vectors, in [0, 1]: ``(1 + cos) / 2``."""
    return float(min(max(1.0 - distance * distance / 4.0, 0.0), 1.0))  # np.clip, cheaper


class QueryChanged(LookupError):
    """The query model of an ``indexed_query`` is no longer ready under the partition the
    index holds it in (deleted, re-described or being described since the last sync)."""


def without_query(rows: list[Row[Any]], query_id: int, key: PartitionKey) -> list[Row[Any]]:
    """The candidate rows without the query model's own, which must still be ready under
    the partition ``key`` (else ``QueryChanged``)."""
    own = [row for row in rows if row.index_id == query_id]
    if not own or own[0].descriptor_version != key[1]:
        raise QueryChanged(query_id)
    return [row for row in rows if row.index_id != query_id]


def ready_candidates(
    connection: Connection, tenant: str, ids: list[int], *extra: str
) -> list[Any]:
    """The tenant's ready models among ``ids``: rows (named tuples) of the columns of a
    ``Candidate`` and the ``extra`` columns named.

    Plain rows of the columns an answer needs, not ORM objects, read by one statement whose
    text is made once per dialect, columns and (on SQLite) number of ids, and run as driver
    SQL: SQLAlchemy's statement cache and result processing cost more than the statement
    itself. Its driver-level errors still go through SQLAlchemy (a lost connection
    invalidates the pool, ``app.db.errors``). The values are those SQLAlchemy's types give:
    UUID objects and decoded metadata (PostgreSQL's driver decodes them itself)."""
    if not ids:
        return []
    shape = _row_shape(extra)
    if connection.dialect.name == "postgresql":
        result = connection.exec_driver_sql(shape.postgres, ([int(i) for i in ids], tenant))
        return [shape.make(row) for row in result]
    # SQLite in-process: the driver's own cursor (its errors raised as SQLAlchemy's, as
    # ``exec_driver_sql`` would: ``app.db.errors``).
    sql = shape.sqlite % ",".join("?" * len(ids))
    values = (*map(int, ids), tenant)
    driver: Any = connection.connection.driver_connection
    try:
        rows = driver.execute(sql, values).fetchall()
    except sqlite3.Error as error:
        raise DBAPIError.instance(sql, values, error, sqlite3.Error) from error
    make, loads, to_uuid = shape.make, json_loads, uuid.UUID
    return [
        make((row[0], to_uuid(row[1]), row[2], row[3],
              None if row[4] is None else loads(row[4]), *row[5:]))
        for row in rows
    ]


@dataclass(frozen=True)
class _RowShape:
    """A ``ready_candidates`` statement's text for each dialect and the type of its rows."""

    postgres: str
    sqlite: str  # with one ``%s`` for the ids' placeholders
    make: Callable[[Any], Any]


@functools.lru_cache(maxsize=16)
def _row_shape(extra: tuple[str, ...]) -> _RowShape:
    names = ("index_id", "id", "external_id", "name", "meta",
             *(f"size_{name}" for name in SIZE_FIELDS), "units", *extra)
    columns = ", ".join(_column(name) for name in names)
    query = f"SELECT {columns} FROM {Model.__tablename__} WHERE "
    ready = "tenant = {0} AND status = 'ready'"
    row = collections.namedtuple("CandidateRow", names)  # type: ignore[misc]
    return _RowShape(
        postgres=query + "index_id = ANY(%s::bigint[]) AND " + ready.format("%s"),
        sqlite=query + "index_id IN (%s) AND " + ready.format("?"),
        make=row._make,
    )


def _column(attribute: str) -> str:
    """The column name of ``Model.<attribute>`` (``meta`` is stored as ``metadata``)."""
    return str(getattr(Model, attribute).property.columns[0].name)


def candidate_of(row: Row[Any]) -> Candidate:
    """The ``Candidate`` of a ``ready_candidates`` row."""
    size = None
    if row.size_length is not None:
        size = ShapeSize(*(getattr(row, f"size_{name}") for name in SIZE_FIELDS))
    return Candidate(row.index_id, row.id, row.external_id, row.name, row.meta, size, row.units)


def first_passing(connection: Connection, tenant: str, ranked: list[int],
                  screened: dict[int, Row[Any] | None], passes: Callable[[Row[Any]], bool],
                  wanted: int) -> list[int]:
    """The first ``wanted`` of ``ranked`` (nearest first) whose rows are ready and pass,
    their rows read ``2 * wanted`` at a time as far as needed and kept in ``screened``
    (id -> row; None: gone, or refused by ``passes``)."""
    passing: list[int] = []
    for start in range(0, len(ranked), 2 * wanted):
        chunk = ranked[start : start + 2 * wanted]
        unread = [i for i in chunk if i not in screened]
        rows = {row.index_id: row for row in ready_candidates(connection, tenant, unread)}
        for i in unread:
            row = rows.get(i)
            screened[i] = row if row is not None and passes(row) else None
        passing += [i for i in chunk if screened[i] is not None]
        if len(passing) >= wanted:
            break
    return passing[:wanted]

