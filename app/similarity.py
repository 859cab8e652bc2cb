"""Similarity queries: nearest descriptors from the index, confirmed, re-ranked and filtered
by the database, scored.

Score: descriptors are unit vectors, so the L2 distance ``d`` lies in [0, 2] and
``score = 1 - d**2 / 4`` (clipped to [0, 1]) equals ``(1 + cos) / 2``: 1 for identical
descriptors, 0.5 for orthogonal ones, 0 for opposite ones.

Every candidate is re-read from the database, the source of truth: a model deleted by
another process a moment ago is never returned. When the partition is approximate
(IVF-SQ8, see ``app.index``) the same query reads the candidates' full descriptors and the
distances are recomputed exactly, so scores never carry quantisation error.

Metadata filters, two ways, and either way "k results whenever k matching models exist":

* selective (at most ``pushdown_max`` models match): the matching ids are selected in SQL
  (``jsonb @>`` on PostgreSQL, served by a GIN index; ``json_extract`` on SQLite) and only
  those ids are searched (a FAISS ``IDSelectorBatch``);
* otherwise the index is searched for more and more candidates (x4 each round) until ``k``
  of them pass the filters or the partition is exhausted; matches are then common, so few
  rounds are needed.

SQL only narrows the candidates; ``metadata_matches`` decides, so both ways agree exactly.

Two modes (``SearchMode``): ``shape`` compares the query with each model's descriptor;
``scan``, for partial scans, also with the descriptors of each model's virtual partial views
(``app.index.views_key``). A model's distance is then that of its best entry (the whole
model or one view), recomputed exactly from the stored descriptors, and each model is one
result. Both partitions are searched for more and more candidates until ``k`` of them are
certain: no model not yet seen can be nearer than the last hit of a partition not exhausted.
"""

from __future__ import annotations

import json
import uuid
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from sqlalchemy import (
    BigInteger,
    ColumnElement,
    Connection,
    Row,
    and_,
    any_,
    bindparam,
    cast,
    false,
    func,
    literal,
    or_,
    select,
)
from sqlalchemy.dialects.postgresql import ARRAY, JSONB

from app.db.models import Model
from app.index import PartitionKey, ShapeIndex, views_key

__all__ = [
    "Candidate",
    "Match",
    "QueryChanged",
    "SearchMode",
    "find_similar",
    "matching_ids",
    "metadata_matches",
    "score_of",
]

PUSHDOWN_MAX = 10_000

#: ``shape``: whole models only (the default); ``scan``: best of each model and its views.
SearchMode = Literal["shape", "scan"]


@dataclass(frozen=True)
class Candidate:
    """What an answer shows of a matching model (the fields of ``ModelSummary``)."""

    index_id: int
    id: uuid.UUID
    external_id: str | None
    name: str | None
    meta: dict[str, Any] | None


@dataclass(frozen=True)
class Match:
    """One result; ``view`` is the view that matched best in scan mode (None: the whole
    model, and always in shape mode)."""

    model: Candidate
    distance: float
    score: float
    view: int | None = None


def score_of(distance: float) -> float:
    return float(np.clip(1.0 - distance * distance / 4.0, 0.0, 1.0))


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


def _sql_filter(connection: Connection, filters: dict[str, str]) -> ColumnElement[bool]:
    """A SQL condition true for every model that ``metadata_matches`` (perhaps a few more)."""
    conditions = []
    postgres = connection.dialect.name == "postgresql"
    for key, wanted in filters.items():
        values = _values_written_as(wanted)
        if postgres:
            document = cast(Model.meta, JSONB)
            options = [
                document.op("@>")(cast(literal(json.dumps({key: v})), JSONB)) for v in values
            ]
        else:
            path = '$."' + key.replace("\\", "\\\\").replace('"', '\\"') + '"'
            extracted = func.json_extract(Model.meta, path)
            options = [
                extracted == (json.dumps(v) if isinstance(v, list | dict) else v)
                for v in values
                if v is not None
            ] or [false()]
        conditions.append(or_(*options))
    return and_(*conditions)


def matching_ids(
    connection: Connection, key: PartitionKey, filters: dict[str, str], limit: int
) -> list[int] | None:
    """The ids of the ready models of partition ``key`` that pass ``filters``, or None when
    more than ``limit`` do (the filter is not selective)."""
    tenant, version = key
    ids = connection.scalars(
        select(Model.index_id)
        .where(
            Model.tenant == tenant,
            Model.descriptor_version == version,
            Model.status == "ready",
            _sql_filter(connection, filters),
        )
        .limit(limit + 1)
    ).all()
    return None if len(ids) > limit else list(ids)


def find_similar(
    index: ShapeIndex,
    connection: Connection,
    key: PartitionKey,
    vector: np.ndarray,
    *,
    k: int,
    min_score: float | None = None,
    filters: dict[str, str] | None = None,
    exclude: int | None = None,
    pushdown_max: int = PUSHDOWN_MAX,
    mode: SearchMode = "shape",
    indexed_query: bool = False,
) -> list[Match]:
    """The ``k`` best matches in partition ``key`` (tenant, descriptor version); in
    ``scan`` mode each model's best entry counts (see the module's docstring).

    ``indexed_query`` (shape mode): ``vector`` is the index's copy of model ``exclude``
    (``ShapeIndex.vector``), not read from the database. That model's row is then confirmed
    in the statement that confirms the first candidates, one statement for the whole query,
    and in an approximate partition its stored descriptor replaces the decoded copy for the
    exact distances. Raises ``QueryChanged`` when the row is no longer ready under ``key``.
    """
    filters = filters or {}
    vector = np.ascontiguousarray(vector, dtype=np.float32).ravel()
    allowed = matching_ids(connection, key, filters, pushdown_max) if filters else None
    if allowed is not None:
        allowed = [i for i in allowed if i != exclude]
    if mode == "scan":
        return _best_entries(
            index, connection, key, vector, k, min_score, filters, exclude, allowed
        )
    approximate = index.is_approximate(key)
    wanted = k + 1 if exclude is not None else k
    fetch = index.rerank_candidates(wanted) if approximate else wanted
    if filters and allowed is None:
        fetch *= 4
    matches: list[Match] = []
    seen: set[int] = set()
    query_id = exclude if indexed_query else None
    while True:
        hits = index.search(key, vector, fetch, allowed=allowed)
        fresh = [i for i, _ in hits if i not in seen and i != exclude]
        seen.update(i for i, _ in hits)
        extra = [Model.descriptor] if approximate else []
        if query_id is None:
            rows = _ready_candidates(connection, key[0], fresh, *extra)
        else:  # the query model's own row rides along, once
            rows = _ready_candidates(
                connection, key[0], [*fresh, query_id], *extra, Model.descriptor_version
            )
            vector, rows = _stored_query(rows, query_id, key, vector, approximate)
            query_id = None
        for model, distance in _confirmed(rows, vector, dict(hits), approximate):
            if metadata_matches(model.meta or {}, filters):
                matches.append(Match(model, distance, score_of(distance)))
        matches.sort(key=lambda match: (match.distance, match.model.index_id))
        if min_score is not None:
            matches = [m for m in matches if m.score >= min_score]
        exhausted = len(hits) < fetch or fetch >= index.partition_size(key)
        # Hits come nearest first: past min_score, nothing further can qualify.
        below_min = min_score is not None and bool(hits) and score_of(hits[-1][1]) < min_score
        if len(matches) >= k or exhausted or below_min or (allowed is not None and not approximate):
            # Equal distances (identical files) in upload order, whatever order the index
            # happened to insert them in: every process answers alike.
            return matches[:k]
        fetch *= 4


class QueryChanged(LookupError):
    """The query model of an ``indexed_query`` is no longer ready under the partition the
    index holds it in (deleted, re-described or being described since the last sync)."""


def _stored_query(
    rows: list[Row[Any]], query_id: int, key: PartitionKey, vector: np.ndarray, exact: bool
) -> tuple[np.ndarray, list[Row[Any]]]:
    """The query vector to re-rank with (the stored descriptor when ``exact``) and the
    candidate rows without the query model's own."""
    own = [row for row in rows if row.index_id == query_id]
    if not own or own[0].descriptor_version != key[1]:
        raise QueryChanged(query_id)
    stored = own[0].descriptor if exact else None
    if stored is not None and len(stored) == 4 * len(vector):
        vector = np.frombuffer(stored, dtype=np.float32)
    return vector, [row for row in rows if row.index_id != query_id]


def _confirmed(
    rows: list[Row[Any]], query: np.ndarray, distances: dict[int, float], exact: bool
) -> list[tuple[Candidate, float]]:
    """The candidates of ``rows`` (still ready in the database), with exact distances when
    ``exact`` (from their stored descriptors) and the index's own otherwise."""
    found = [distances[row.index_id] for row in rows]
    if exact:
        # One vectorised pass over the stored descriptors (a few dozen); a row whose
        # descriptor is missing or of another length keeps the index's distance.
        usable = [
            i
            for i, row in enumerate(rows)
            if row.descriptor and len(row.descriptor) == 4 * len(query)
        ]
        if usable:
            stored = np.frombuffer(b"".join(rows[i].descriptor for i in usable), dtype=np.float32)
            exact_distances = np.linalg.norm(stored.reshape(len(usable), -1) - query, axis=1)
            for i, distance in zip(usable, exact_distances.tolist(), strict=True):
                found[i] = distance
    return [(_candidate(row), distance) for row, distance in zip(rows, found, strict=True)]


def _ready_candidates(
    connection: Connection, tenant: str, ids: list[int], *extra: ColumnElement[Any]
) -> list[Row[Any]]:
    """The tenant's ready models among ``ids``: the columns of a ``Candidate`` and ``extra``.

    Plain rows of the columns an answer needs, not ORM objects: building and tracking a
    few dozen ``Model`` instances per query cost more than the query itself."""
    if not ids:
        return []
    statement = select(
        Model.index_id, Model.id, Model.external_id, Model.name, Model.meta.label("meta"), *extra
    ).where(_id_in(connection, ids), Model.tenant == tenant, Model.status == "ready")
    return list(connection.execute(statement, {"ids": ids}))


def _candidate(row: Row[Any]) -> Candidate:
    return Candidate(row.index_id, row.id, row.external_id, row.name, row.meta)


def _id_in(connection: Connection, ids: list[int]) -> ColumnElement[bool]:
    """``index_id`` among the bound parameter ``ids``: one array parameter on PostgreSQL,
    so the statement text is the same for any number of ids and is prepared once per
    connection; an expanded ``IN`` elsewhere."""
    if connection.dialect.name == "postgresql":
        return Model.index_id == any_(bindparam("ids", type_=ARRAY(BigInteger)))
    return Model.index_id.in_(bindparam("ids", expanding=True))


def _best_entries(
    index: ShapeIndex,
    connection: Connection,
    key: PartitionKey,
    vector: np.ndarray,
    k: int,
    min_score: float | None,
    filters: dict[str, str],
    exclude: int | None,
    allowed: list[int] | None,
) -> list[Match]:
    """Scan mode's ``find_similar``: the ``k`` models whose best entry is nearest."""
    sizes = (index.partition_size(key), index.partition_size(views_key(key)))
    # Views per model (on average): a model's views tend to be near the query together.
    per_model = max(1, -(-sizes[1] // max(sizes[0], 1)))
    fetch = (k + 1 if exclude is not None else k) * (4 if filters and allowed is None else 1)
    if index.is_approximate(key) or index.is_approximate(views_key(key)):
        fetch = index.rerank_candidates(fetch)  # estimated distances: a margin of candidates
    matches: dict[int, Match] = {}
    seen: set[int] = set()
    while True:
        wanted = (fetch, fetch * per_model)
        model_hits = index.search(key, vector, wanted[0], allowed=allowed)
        view_hits = index.search_views(key, vector, wanted[1], allowed=allowed)
        found = [i for i, _ in model_hits] + [i for i, _, _ in view_hits]
        fresh = [i for i in dict.fromkeys(found) if i not in seen and i != exclude]
        seen.update(found)
        for model, distance, view in _confirmed_best(connection, key[0], fresh, vector):
            if metadata_matches(model.meta or {}, filters):
                matches[model.index_id] = Match(model, distance, score_of(distance), view)
        # A model not seen yet is no nearer than the last hit of each partition not yet
        # exhausted (inf when both are): matches up to that bound are certain.
        bound = float("inf")
        for hits, asked, size in zip((model_hits, view_hits), wanted, sizes, strict=True):
            if len(hits) == asked and asked < size:
                bound = min(bound, hits[-1][-1])
        ranked = sorted(matches.values(), key=lambda m: (m.distance, m.model.index_id))
        if min_score is not None:
            ranked = [m for m in ranked if m.score >= min_score]
        # Exact distances against the index's float32 ones: allow for rounding.
        certain = [m for m in ranked if m.distance <= bound + 1e-5]
        past_min = min_score is not None and score_of(bound) < min_score
        if len(certain) >= k or bound == float("inf") or past_min:
            return certain[:k]
        fetch *= 4


def _confirmed_best(
    connection: Connection, tenant: str, ids: list[int], query: np.ndarray
) -> list[tuple[Candidate, float, int | None]]:
    """The candidates still ready in the database, each with the exact distance of its
    best entry (read from the stored descriptors) and which one it is (None: the model)."""
    confirmed = []
    for row in _ready_candidates(connection, tenant, ids, Model.descriptor, Model.view_descriptors):
        if row.descriptor is None:
            continue
        entries = [np.frombuffer(row.descriptor, dtype=np.float32)]
        if row.view_descriptors:
            entries += list(
                np.frombuffer(row.view_descriptors, np.float32).reshape(-1, len(entries[0]))
            )
        if len(entries[0]) != len(query):
            continue
        distances = np.linalg.norm(np.stack(entries) - query, axis=1)
        best = int(np.argmin(distances))
        confirmed.append((_candidate(row), float(distances[best]), None if best == 0 else best - 1))
    return confirmed
