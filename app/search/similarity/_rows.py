"""What the database confirms of a candidate, and what an answer shows of it.

Every candidate the index finds is confirmed by the database, the source of truth, in one
statement of the few columns an answer shows (``ready_candidates``): a model deleted by
another process a moment ago is never returned.
"""

from __future__ import annotations

import functools
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from sqlalchemy import BigInteger, Connection, Row, Select, any_, bindparam, select
from sqlalchemy.dialects.postgresql import ARRAY

from app.db.models import Model
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
    return float(np.clip(1.0 - distance * distance / 4.0, 0.0, 1.0))


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
) -> list[Row[Any]]:
    """The tenant's ready models among ``ids``: the columns of a ``Candidate`` and the
    ``extra`` columns named.

    Plain rows of the columns an answer needs, not ORM objects: building and tracking a
    few dozen ``Model`` instances per query cost more than the query itself; the statement
    is built once per dialect and columns (building it per query cost a third of its time)."""
    if not ids:
        return []
    statement = _candidates_statement(connection.dialect.name == "postgresql", extra)
    return list(connection.execute(statement, {"ids": ids, "tenant": tenant}))


@functools.lru_cache(maxsize=16)
def _candidates_statement(postgres: bool, extra: tuple[str, ...]) -> Select[Any]:
    # ``index_id`` among the bound parameter ``ids``: one array parameter on PostgreSQL,
    # so the statement text is the same for any number of ids and is prepared once per
    # connection; an expanded ``IN`` elsewhere.
    among = (
        Model.index_id == any_(bindparam("ids", type_=ARRAY(BigInteger)))
        if postgres
        else Model.index_id.in_(bindparam("ids", expanding=True))
    )
    return select(
        Model.index_id,
        Model.id,
        Model.external_id,
        Model.name,
        Model.meta.label("meta"),
        *(getattr(Model, f"size_{name}") for name in SIZE_FIELDS),
        Model.units,
        *(getattr(Model, name) for name in extra),
    ).where(among, Model.tenant == bindparam("tenant"), Model.status == "ready")


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

