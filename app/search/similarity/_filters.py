"""Metadata filters: the predicate that decides (``metadata_matches``,
``metadata_in_ranges``) and the SQL that narrows the candidates to the models it may pass
(``matching_ids``), on either backend; SQL only narrows, so both ways agree exactly. An
assembly filter (``assembly_part_ids``) is always narrow: its parts' ids are searched alone.
"""

from __future__ import annotations

import json
import uuid
from typing import Any

from sqlalchemy import (
    ColumnElement,
    Connection,
    Float,
    and_,
    case,
    cast,
    column,
    false,
    func,
    literal,
    or_,
    select,
    table,
    true,
)
from sqlalchemy.dialects.postgresql import JSONB

from app.db.models import AssemblyPart, Model
from app.search.index import PartitionKey
from app.search.sizing import SizeQuery

# SQLite's metadata entries, kept by triggers (migrations/versions/0007_metadata_values.py).
_METADATA_VALUES = table(
    "metadata_values", column("index_id"), column("tenant"), column("key"), column("value")
)


def metadata_matches(metadata: dict[str, Any], filters: dict[str, str]) -> bool:
    """Equality on every filter; non-string values compare by their JSON text (3, true)."""
    for key, wanted in filters.items():
        if key not in metadata:
            return False
        value = metadata[key]
        text = value if isinstance(value, str) else json.dumps(value)
        if text != wanted:
            return False
    return True


#: Metadata key -> (lowest, highest) allowed number; None: unbounded on that side.
Ranges = dict[str, tuple[float | None, float | None]]


def metadata_in_ranges(metadata: dict[str, Any], ranges: Ranges) -> bool:
    """Whether every ranged key holds a JSON number (not a boolean) within its range."""
    for key, (low, high) in ranges.items():
        value = metadata.get(key)
        if isinstance(value, bool) or not isinstance(value, int | float):
            return False
        if (low is not None and value < low) or (high is not None and value > high):
            return False
    return True


def sql_ranges(connection: Connection, ranges: Ranges) -> ColumnElement[bool]:
    """A SQL condition true for every model whose metadata ``metadata_in_ranges``; a
    non-numeric value reads as NULL (a CASE, so no cast ever fails)."""
    conditions: list[ColumnElement[bool]] = []
    postgres = connection.dialect.name == "postgresql"
    for key, (low, high) in ranges.items():
        if postgres:
            document = cast(Model.meta, JSONB)
            number = case(
                (func.jsonb_typeof(document[key]) == "number",
                 cast(document[key].astext, Float)),
            )
        else:
            path = '$."' + key.replace('"', '\\"') + '"'
            number = case(
                (func.json_type(Model.meta, path).in_(("integer", "real")),
                 func.json_extract(Model.meta, path)),
            )
        conditions.append(number.is_not(None))
        if low is not None:
            conditions.append(number >= low)
        if high is not None:
            conditions.append(number <= high)
    return and_(true(), *conditions)


def _values_written_as(wanted: str) -> list[Any]:
    """The JSON values whose filter text is ``wanted``: the string itself and, when
    ``wanted`` is the exact JSON text of a non-string, that value."""
    values: list[Any] = [wanted]
    try:
        parsed = json.loads(wanted)
    except ValueError:
        return values
    if not isinstance(parsed, str) and json.dumps(parsed) == wanted:
        values.append(parsed)
    return values


def sql_filter(
    connection: Connection, tenant: str, filters: dict[str, str]
) -> ColumnElement[bool]:
    """A SQL condition true for every model of ``tenant`` that ``metadata_matches`` (perhaps
    a few more), served by an index on either backend."""
    conditions = []
    postgres = connection.dialect.name == "postgresql"
    for key, wanted in filters.items():
        if postgres:  # the GIN index of migration 0005
            document = cast(Model.meta, JSONB)
            conditions.append(or_(*(
                document.op("@>")(cast(literal(json.dumps({key: v})), JSONB))
                for v in _values_written_as(wanted))))
            continue
        entries = _entries(tenant, key, wanted)
        conditions.append(false() if entries is None else Model.index_id.in_(
            select(_METADATA_VALUES.c.index_id).where(*entries)))
    return and_(true(), *conditions)


def _entries(tenant: str, key: str, wanted: str) -> list[ColumnElement[bool]] | None:
    """SQLite: the conditions that select ``tenant``'s metadata entries (migration 0007)
    that filter text ``wanted`` of ``key`` names; None when no entry can (a JSON null). The
    entries' values are json_each's: text, numbers (true and false as 1 and 0), compact
    JSON text."""
    values = [
        json.dumps(v, separators=(",", ":")) if isinstance(v, list | dict) else v
        for v in _values_written_as(wanted)
        if v is not None
    ]
    if not values:
        return None
    return [_METADATA_VALUES.c.tenant == tenant, _METADATA_VALUES.c.key == key,
            _METADATA_VALUES.c.value.in_(values)]


def _some_filter_narrow(tenant: str, filters: dict[str, str], limit: int
                        ) -> ColumnElement[bool]:
    """SQLite: true when some equality filter names at most ``limit`` of ``tenant``'s
    metadata entries (each counted up to ``limit + 1`` from the entries' index alone, which
    holds tenant, key and value). Else more than ``limit`` models may pass, and
    ``matching_ids`` says so without checking each one's partition."""
    narrow: list[ColumnElement[bool]] = []
    for key, wanted in filters.items():
        entries = _entries(tenant, key, wanted)
        if entries is None:
            return true()  # nothing passes: the full statement answers at once
        named = select(literal(1)).select_from(_METADATA_VALUES).where(*entries)
        counted = select(func.count()).select_from(named.limit(limit + 1).subquery())
        narrow.append(counted.scalar_subquery() <= limit)
    return or_(*narrow)


def assembly_part_ids(connection: Connection, tenant: str, assembly_id: uuid.UUID
                      ) -> list[int]:
    """The ``index_id`` of every model the tenant's assembly ``assembly_id`` places (its
    distinct parts: at most ``SHAPESEARCH_ASSEMBLY_MAX_PARTS``); none for an unknown id."""
    return list(connection.scalars(
        select(Model.index_id).where(
            Model.tenant == tenant,
            Model.id.in_(select(AssemblyPart.part_id).where(
                AssemblyPart.tenant == tenant, AssemblyPart.assembly_id == assembly_id)),
        )
    ))


def matching_ids(
    connection: Connection,
    key: PartitionKey,
    filters: dict[str, str],
    limit: int,
    size: SizeQuery | None = None,
    ranges: Ranges | None = None,
    within: list[int] | None = None,
) -> list[int] | None:
    """The ids of the ready models of partition ``key`` that pass ``filters`` and the size
    filters (and are among ``within``, when given), or None when more than ``limit`` do (the
    filter is not selective): the search then screens the nearest candidates' rows instead,
    with the same answers. With ``within``, never None: at most ``len(within)`` pass.

    On SQLite, with equality filters, None also when each of them names more than ``limit``
    of the tenant's metadata entries, counted from their index alone, before any model's
    partition is checked: for a filter that 15,000 of 2 x 10^4 models pass, checking ids
    until more than 10,000 were ready in the partition took 13.0 ms, counting its entries
    1.7 ms; one that 2,000 pass costs 0.4 ms more (3.6 -> 4.0 ms; the statement is larger).
    A filter broad across the tenant but narrow in the partition (most of its models on
    another descriptor version, mid re-describe) is then screened too.

    Up to ``limit + 1`` ids come back as one value, an array (PostgreSQL) or a JSON list
    (SQLite), not as rows: 10,001 rows made in Python cost a third of a broad filter's
    time, and the allocations set off the collector's full passes (a query's 14 ms became
    65-123 ms in one query of ten, 2 x 10^4 models)."""
    tenant, version = key
    if within is not None:
        limit = len(within)
    matches = (
        select(Model.index_id)
        .where(
            Model.index_id.in_(within) if within is not None else true(),
            Model.tenant == tenant,
            Model.descriptor_version == version,
            Model.status == "ready",
            sql_filter(connection, tenant, filters),
            size.sql() if size is not None else true(),
            sql_ranges(connection, ranges) if ranges else true(),
        )
        .limit(limit + 1)
        .subquery()
    )
    if connection.dialect.name == "postgresql":
        ids: list[int] = connection.scalar(select(func.array_agg(matches.c.index_id))) or []
        return None if len(ids) > limit else ids
    listed = select(func.json_group_array(matches.c.index_id)).scalar_subquery()
    # One statement: SQLite computes the list only when the case asks for it.
    found = connection.scalar(select(
        case((_some_filter_narrow(tenant, filters, limit), listed))
        if filters and within is None else listed))
    if found is None:
        return None
    ids = json.loads(found)
    return None if len(ids) > limit else ids

