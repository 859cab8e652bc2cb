"""Similarity queries: nearest descriptors from the index, confirmed, re-ranked and filtered
by the database, scored.

Score: descriptors are unit vectors, so the L2 distance ``d`` lies in [0, 2] and
``score = 1 - d**2 / 4`` (clipped to [0, 1]) equals ``(1 + cos) / 2``: 1 for identical
descriptors, 0.5 for orthogonal ones, 0 for opposite ones.

Every candidate is confirmed by the database, the source of truth, in one statement of
the few columns an answer shows: a model deleted by another process a moment ago is never
returned. When the partition is approximate (IVF-SQ, see ``app.search.index``) the distances are
recomputed exactly from the full vectors the index keeps (``app.search.full_vectors``), so scores
never carry quantisation error.

Metadata filters, two ways, and either way "k results whenever k matching models exist":

* selective (at most ``pushdown_max`` models match): the matching ids are selected in SQL
  (``jsonb @>`` on PostgreSQL, served by a GIN index; on SQLite from a table of metadata
  entries indexed on (tenant, key, value), kept by triggers) and only those ids are
  searched (a FAISS ``IDSelectorBatch``);
* otherwise the index is searched for more and more candidates (x4 each round) until ``k``
  of them pass the filters or the partition is exhausted; matches are then common, so few
  rounds are needed. With the hub discount the nearest candidates' rows are read first,
  a few at a time, until the pool the discount orders is full of models that pass
  (``_screened``).

Numeric ranges on metadata (``metadata.KEY.gte=``, ``.lte=``, ``metadata_ranges``) work the
same way: a value passes when it is a JSON number (not a boolean) within the range.

SQL only narrows the candidates; ``metadata_matches`` and ``metadata_in_ranges`` decide, so
both ways agree exactly.

Two modes (``SearchMode``): ``shape`` compares the query with each model's descriptor;
``scan``, for partial scans, also with the descriptors of each model's virtual partial views
(``app.search.index.views_key``). A model's distance is then that of its best entry (the
whole model or one view), computed exactly from the index's vectors as added (a compressed
partition's full vectors, as in shape mode), and each model is one result. Both partitions
are searched for more and more candidates until ``k`` of them are certain: no model not yet
seen can be nearer than the last hit of a partition not exhausted.

Order: shape mode ranks with a hub discount (cross-domain similarity local scaling,
``core.hubness``): the ``4 k`` nearest candidates are re-ordered by ``d^2 + r_k``, ``r_k`` a
candidate's mean cosine to its 10 most alike other models of the partition (the index's
``neighbourhood_radii``), so a part near everything comes a little later and the rest of
the query's kind earlier (+0.01 mAP left out over seven tuning sources; docs/results.md).
Then, without a size term, those candidates are re-ranked k-reciprocally among themselves
(``core.reciprocal.pool_keys``: a candidate whose own nearest hold the query comes earlier;
+0.04 mAP on a tuning source that no setting had seen), the hub discount's first answer
kept first (the re-rank alone moved right first answers down). A candidate with the query's
own descriptor stays first. ``distance`` and ``score`` stay plain (``min_score``, the
calibration and the duplicates report keep their meaning). Scan mode has a discount of its
own (``core.hubness.model_radii``): of the ``core.scan_order.scan_depth(k)`` (``max(4 k,
40)``) nearest models by best entry, the one whose best entry has the least ``d^2 + 0.5 r``,
``r`` the entry's mean best cosine to the 5 other models most alike it, comes first (+0.006 mAP
of single-view scans left out over seven sources); the others, joined with the
``core.scan_order.ANCHOR_NEIGHBOURS`` (120) models nearest that first answer's whole
descriptor, follow in the order a shape query for it gives them (``core.scan_order``: a
partial scan is far from every whole model, whole models find their kind well; +0.015 mAP
of single-view scans left out over seven sources against the blend it replaced, itself
+0.073 over the discount alone; the joined neighbours a further +0.013). An entry's
radius costs a search, so entries are taken best bound first (``_scan_hub_order``) and the
index keeps what it searched while the catalogue stays as it is.
"""

from __future__ import annotations

import functools
import heapq
import json
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from sqlalchemy import (
    BigInteger,
    ColumnElement,
    Connection,
    Float,
    Row,
    Select,
    and_,
    any_,
    bindparam,
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
from sqlalchemy.dialects.postgresql import ARRAY, JSONB

from app.db.models import Model
from app.search.index import VIEW_ID_BASE, PartitionKey, ShapeIndex, view_id, views_key
from app.search.sizing import SizeQuery
from core import scan_order
from core.hubness import (
    SAME_DESCRIPTOR,
    SCAN_HUB_NEIGHBOURS,
    SCAN_HUB_WEIGHT,
    hub_keys,
    model_radii,
    model_radii_among,
    rerank_depth,
)
from core.reciprocal import pool_keys, reciprocal_depth
from core.size import SIZE_FIELDS, ShapeSize

__all__ = [
    "Candidate",
    "Match",
    "QueryChanged",
    "SearchMode",
    "find_similar",
    "matching_ids",
    "metadata_in_ranges",
    "metadata_matches",
    "score_of",
]

PUSHDOWN_MAX = 10_000

# SQLite's metadata entries, kept by triggers (migrations/versions/0007_metadata_values.py).
_METADATA_VALUES = table(
    "metadata_values", column("index_id"), column("tenant"), column("key"), column("value")
)

#: ``shape``: whole models only (the default); ``scan``: best of each model and its views.
SearchMode = Literal["shape", "scan"]


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


def _sql_ranges(connection: Connection, ranges: Ranges) -> ColumnElement[bool]:
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


def _sql_filter(
    connection: Connection, tenant: str, filters: dict[str, str]
) -> ColumnElement[bool]:
    """A SQL condition true for every model of ``tenant`` that ``metadata_matches`` (perhaps
    a few more), served by an index on either backend."""
    conditions = []
    postgres = connection.dialect.name == "postgresql"
    for key, wanted in filters.items():
        values = _values_written_as(wanted)
        if postgres:  # the GIN index of migration 0005
            document = cast(Model.meta, JSONB)
            conditions.append(
                or_(
                    *(document.op("@>")(cast(literal(json.dumps({key: v})), JSONB)) for v in values)
                )
            )
            continue
        # SQLite: the (tenant, key, value) entries of migration 0007, whose values are
        # json_each's: text, numbers (true and false as 1 and 0), compact JSON text.
        entries = [
            json.dumps(v, separators=(",", ":")) if isinstance(v, list | dict) else v
            for v in values
            if v is not None
        ]
        if not entries:
            conditions.append(false())
            continue
        conditions.append(
            Model.index_id.in_(
                select(_METADATA_VALUES.c.index_id).where(
                    _METADATA_VALUES.c.tenant == tenant,
                    _METADATA_VALUES.c.key == key,
                    _METADATA_VALUES.c.value.in_(entries),
                )
            )
        )
    return and_(true(), *conditions)


def matching_ids(
    connection: Connection,
    key: PartitionKey,
    filters: dict[str, str],
    limit: int,
    size: SizeQuery | None = None,
    ranges: Ranges | None = None,
) -> list[int] | None:
    """The ids of the ready models of partition ``key`` that pass ``filters`` and the size
    filters, or None when more than ``limit`` do (the filter is not selective).

    Up to ``limit + 1`` ids come back as one value, an array (PostgreSQL) or a JSON list
    (SQLite), not as rows: 10,001 rows made in Python cost a third of a broad filter's
    time, and the allocations set off the collector's full passes (a query's 14 ms became
    65-123 ms in one query of ten, 2 x 10^4 models)."""
    tenant, version = key
    matches = (
        select(Model.index_id)
        .where(
            Model.tenant == tenant,
            Model.descriptor_version == version,
            Model.status == "ready",
            _sql_filter(connection, tenant, filters),
            size.sql() if size is not None else true(),
            _sql_ranges(connection, ranges) if ranges else true(),
        )
        .limit(limit + 1)
        .subquery()
    )
    if connection.dialect.name == "postgresql":
        ids: list[int] = connection.scalar(select(func.array_agg(matches.c.index_id))) or []
    else:
        ids = json.loads(connection.scalar(select(func.json_group_array(matches.c.index_id)))
                         or "[]")
    return None if len(ids) > limit else ids


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
    size: SizeQuery | None = None,
    metadata_ranges: Ranges | None = None,
) -> list[Match]:
    """The ``k`` best matches in partition ``key`` (tenant, descriptor version); in
    ``scan`` mode each model's best entry counts (see the module's docstring).

    ``indexed_query`` (shape mode): ``vector`` is the index's copy of model ``exclude``
    (``ShapeIndex.vector``: the vector as added, in a compressed partition too), not read
    from the database. That model's row is then confirmed in the statement that confirms
    the first candidates, one statement for the whole query. Raises ``QueryChanged`` when
    the row is no longer ready under ``key``.

    ``size`` (``app.search.sizing``): size filters, which narrow the candidates like the
    metadata filters, and a size term that ranks by the combined distance; a match's
    ``distance`` and ``score`` are then the combined ones.

    Shape mode orders its answer with the index's hub discount (``index.hub_neighbours``
    above 0): the ``rerank_depth(k)`` nearest candidates that pass, re-ordered by
    ``core.hubness.hub_keys`` and, with ``index.reciprocal`` and no size term, re-ranked
    k-reciprocally among the ``reciprocal_depth(k)`` nearest (``core.reciprocal``), the
    first ``k`` returned; ``distance`` and ``score`` stay the plain ones, so scores need not
    fall along the answer.
    """
    filters = filters or {}
    size = size or SizeQuery()
    ranges = metadata_ranges or {}
    vector = np.ascontiguousarray(vector, dtype=np.float32).ravel()
    filtered = bool(filters) or bool(ranges) or size.filters
    allowed = (
        matching_ids(connection, key, filters, pushdown_max, size, ranges) if filtered else None
    )
    if allowed is not None:
        allowed = [i for i in allowed if i != exclude]
    if mode == "scan":
        return _best_entries(
            index, connection, key, vector, k, min_score, filters, exclude, allowed, size,
            ranges,
        )
    approximate = index.is_approximate(key)
    discounted = index.hub_neighbours > 0
    # Plain nearest, re-ordered below; a k-reciprocal re-rank takes neighbourhoods among them
    # (not with a size term: its combined distances are no vectors' distances).
    reciprocal = discounted and index.reciprocal and size.weight == 0
    depth = reciprocal_depth(k) if reciprocal else rerank_depth(k) if discounted else k
    wanted = depth + 1 if exclude is not None else depth
    fetch = index.rerank_candidates(key, wanted)
    if filtered and allowed is None:
        fetch *= 4
    if discounted and size.weight == 0:
        answer = _hub_answer(
            index, connection, key, vector, k, depth, fetch, min_score, exclude,
            exclude if indexed_query else None, allowed,
            lambda row: _passes(row, filters, ranges, size), screen=filtered and allowed is None)
        if answer is not None:
            return answer
    matches: list[Match] = []
    seen: set[int] = set()
    query_id = exclude if indexed_query else None
    while True:
        hits = index.search(key, vector, fetch, allowed=allowed)
        fresh = [i for i, _ in hits if i not in seen and i != exclude]
        seen.update(i for i, _ in hits)
        if query_id is None:
            rows = _ready_candidates(connection, key[0], fresh)
        else:  # the query model's own row rides along, once
            rows = _ready_candidates(connection, key[0], [*fresh, query_id], "descriptor_version")
            rows = _without_query(rows, query_id, key)
            query_id = None
        distances = dict(hits)
        if approximate:  # estimates from the codes: exact ones from the full vectors
            distances.update(_exact_distances(index, key, [row.index_id for row in rows], vector))
        for row in rows:
            if _passes(row, filters, ranges, size):
                distance = size.distance(distances[row.index_id], row)
                matches.append(Match(_candidate(row), distance, score_of(distance)))
        matches.sort(key=lambda match: (match.distance, match.model.index_id))
        if min_score is not None:
            matches = [m for m in matches if m.score >= min_score]
        exhausted = len(hits) < fetch or fetch >= index.partition_size(key)
        # Hits come nearest first: past min_score, nothing further can qualify.
        below_min = min_score is not None and bool(hits) and score_of(hits[-1][1]) < min_score
        # A size term only adds to a distance: a model not seen yet is no nearer than the
        # last hit, so matches up to that bound are certain.
        certain = matches
        if size.weight > 0 and hits and not exhausted:
            certain = [m for m in matches if m.distance <= hits[-1][1] + 1e-5]
        # Not "allowed, so done": SQL may allow a few ids the filters then refuse (a SQLite
        # entry 1 stands for both 1 and true), and the rule is k results whenever k match.
        if len(certain) >= depth or exhausted or below_min:
            # Equal distances (identical files) in upload order, whatever order the index
            # happened to insert them in: every process answers alike.
            nearest = certain[:depth]
            if not discounted:
                return nearest
            return _hub_ordered(index, key, nearest, exclude,
                                vector if reciprocal else None)[:k]
        fetch *= 4


def _screened(connection: Connection, tenant: str, ranked: list[int],
              screened: dict[int, Row[Any] | None], passes: Callable[[Row[Any]], bool],
              wanted: int) -> list[int]:
    """The first ``wanted`` of ``ranked`` (nearest first) whose rows are ready and pass,
    their rows read ``2 * wanted`` at a time as far as needed and kept in ``screened``
    (id -> row; None: gone, or refused by ``passes``)."""
    passing: list[int] = []
    for start in range(0, len(ranked), 2 * wanted):
        chunk = ranked[start : start + 2 * wanted]
        unread = [i for i in chunk if i not in screened]
        rows = {row.index_id: row for row in _ready_candidates(connection, tenant, unread)}
        for i in unread:
            row = rows.get(i)
            screened[i] = row if row is not None and passes(row) else None
        passing += [i for i in chunk if screened[i] is not None]
        if len(passing) >= wanted:
            break
    return passing[:wanted]


def _hub_answer(
    index: ShapeIndex,
    connection: Connection,
    key: PartitionKey,
    vector: np.ndarray,
    k: int,
    depth: int,
    fetch: int,
    min_score: float | None,
    exclude: int | None,
    query_id: int | None,
    allowed: list[int] | None,
    passes: Callable[[Row[Any]], bool],
    screen: bool = False,
) -> list[Match] | None:
    """``find_similar`` with the hub discount, without a size term, unfiltered or with the
    ids that pass the filters ``allowed`` by SQL: the ``depth`` nearest (exact distances)
    are ordered from the index alone, then confirmed by the database in that order, as
    many as the answer takes, so the database reads about ``k`` rows, not ``depth``. None
    when fewer than ``k`` were confirmed (deleted a moment ago, or refused by ``passes``,
    which SQL can let through) while models beyond the ``depth`` nearest may qualify: the
    caller's general search widens instead. A k-reciprocal re-rank takes its neighbourhoods
    among the ``depth`` nearest that SQL allowed, a row ``passes`` then refuses included.

    ``screen``: filters SQL could not narrow to ids. The hits' rows are read nearest first
    until ``depth`` of them pass (``_screened``), and those are the ones ordered."""
    screened: dict[int, Row[Any] | None] = {}  # with screen: read rows (None: refused)
    # The full vectors read for exact distances, kept only for a k-reciprocal re-rank.
    read: dict[int, np.ndarray] | None = {} if index.reciprocal else None
    while True:
        hits = index.search(key, vector, fetch, allowed=allowed)
        ids = [i for i, _ in hits if i != exclude]
        exhausted = len(hits) < fetch or fetch >= index.partition_size(key)
        distances = dict(hits)
        if index.is_approximate(key):  # estimates from the codes: exact ones, full vectors
            distances.update(_exact_distances(index, key, ids, vector, read))
        ranked = sorted(ids, key=lambda i: (distances[i], i))
        if screen:
            ranked = _screened(connection, key[0], ranked, screened, passes, depth)
        if len(ranked) >= depth or exhausted:
            break
        fetch *= 4
    if screen and query_id is not None:  # the query model's own row, confirmed alone
        _without_query(_ready_candidates(connection, key[0], [query_id], "descriptor_version"),
                       query_id, key)
        query_id = None
    nearest = ranked[:depth]
    beyond = len(ids) > depth or not exhausted  # more candidates than those ordered here
    if min_score is not None:
        qualifying = [i for i in nearest if score_of(distances[i]) >= min_score]
        beyond = beyond and len(qualifying) == len(nearest)
        nearest = qualifying
    # A query by model id is that model's own vector, at plain distances here.
    order = _hub_order(index, key, nearest, [distances[i] for i in nearest], exclude,
                       query_is_excluded=True, query=vector, read=read)
    matches: list[Match] = []
    for start in range(0, max(len(order), 1), k):
        chunk = order[start : start + k]
        if screen:
            rows = [row for row in (screened[i] for i in chunk) if row is not None]
        elif query_id is None:
            rows = _ready_candidates(connection, key[0], chunk)
        else:  # the query model's own row rides along, once
            rows = _without_query(_ready_candidates(connection, key[0], [*chunk, query_id],
                                                    "descriptor_version"), query_id, key)
            query_id = None
        by_id = {row.index_id: row for row in rows if passes(row)}
        matches += [Match(_candidate(by_id[i]), distances[i], score_of(distances[i]))
                    for i in chunk if i in by_id]
        if len(matches) >= k:
            return matches[:k]
    return None if beyond else matches


def _hub_order(index: ShapeIndex, key: PartitionKey, ids: list[int], distances: list[float],
               exclude: int | None, query_is_excluded: bool = False,
               query: np.ndarray | None = None,
               read: dict[int, np.ndarray] | None = None) -> list[int]:
    """``ids`` (nearest first, at plain ``distances``, or combined ones with a size term) in
    the order of the hub discount (``core.hubness.hub_keys``), the query model ``exclude``
    in no neighbourhood (``query_is_excluded``: the query vector is its own and the
    distances plain, so its cosines are known); ties in upload order. An id the index
    dropped since it was found (deleted a moment ago) takes the largest radius among the
    others. With the index's ``reciprocal`` and the ``query`` vector (plain distances),
    that order is re-ranked k-reciprocally among ``ids`` (``_reciprocal_keys``; ``read``:
    vectors already read, by id)."""
    # Then the excluded model's cosine to each candidate is 1 - d^2 / 2: no vectors read.
    known = query_is_excluded and exclude is not None
    radii = index.neighbourhood_radii(
        key, ids, exclude, [1.0 - d * d / 2.0 for d in distances] if known else None)
    if not radii:
        return ids
    largest = max(radii.values())
    keys = hub_keys(np.square(distances), np.array([radii.get(i, largest) for i in ids]))
    if index.reciprocal and query is not None:
        keys = _reciprocal_keys(index, key, ids, keys, query, read or {})
    return [ids[j] for j in sorted(range(len(ids)), key=lambda j: (keys[j], ids[j]))]


def _reciprocal_keys(index: ShapeIndex, key: PartitionKey, ids: list[int], hub: np.ndarray,
                     query: np.ndarray, read: dict[int, np.ndarray]) -> np.ndarray:
    """``core.reciprocal.pool_keys`` of ``ids`` for ``query`` (their ``hub`` keys as its
    blended term), from the vectors the index holds (those in ``read`` already read); an
    id it dropped since it was found comes after the others. ``hub`` itself when fewer than
    two are held."""
    if all(i in read for i in ids):
        found: tuple[np.ndarray, np.ndarray] | None = (
            np.array([read[i] for i in ids]), np.ones(len(ids), dtype=bool))
    else:
        found = index.exact_vectors(key, ids)
    if found is None or int(found[1].sum()) < 2:
        return hub
    vectors, held = found
    keys = np.full(len(ids), np.inf)
    keys[held] = pool_keys(query, vectors[held], hub[held])
    return keys


def _hub_ordered(
    index: ShapeIndex, key: PartitionKey, matches: list[Match], exclude: int | None,
    query: np.ndarray | None,
) -> list[Match]:
    """``matches`` (nearest first) re-ordered by the hub discount (``_hub_order``), and
    k-reciprocally with the ``query`` vector."""
    by_id = {m.model.index_id: m for m in matches}
    order = _hub_order(index, key, list(by_id), [m.distance for m in matches], exclude,
                       query=query)
    return [by_id[i] for i in order]


class QueryChanged(LookupError):
    """The query model of an ``indexed_query`` is no longer ready under the partition the
    index holds it in (deleted, re-described or being described since the last sync)."""


def _without_query(rows: list[Row[Any]], query_id: int, key: PartitionKey) -> list[Row[Any]]:
    """The candidate rows without the query model's own, which must still be ready under
    the partition ``key`` (else ``QueryChanged``)."""
    own = [row for row in rows if row.index_id == query_id]
    if not own or own[0].descriptor_version != key[1]:
        raise QueryChanged(query_id)
    return [row for row in rows if row.index_id != query_id]


def _exact_distances(
    index: ShapeIndex, key: PartitionKey, ids: list[int], query: np.ndarray,
    read: dict[int, np.ndarray] | None = None,
) -> dict[int, float]:
    """Exact L2 distances from ``query`` to the full vectors of ``ids`` that partition
    ``key`` holds, in one vectorised pass; each vector read is also put in ``read`` (by id)
    when given, for a re-rank that needs them again."""
    found = index.exact_vectors(key, ids) if ids else None
    if found is None:
        return {}
    vectors, held = found
    distances = np.linalg.norm(vectors - query, axis=1).tolist()
    if read is not None:
        read.update((i, row) for i, row, h in zip(ids, vectors, held.tolist(), strict=True)
                    if h)
    return {i: d for i, d, h in zip(ids, distances, held.tolist(), strict=True) if h}


def _ready_candidates(
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


def _passes(row: Row[Any], filters: dict[str, str], ranges: Ranges, size: SizeQuery) -> bool:
    """Whether a candidate row passes every filter (metadata equality and ranges, size)."""
    meta = row.meta or {}
    return metadata_matches(meta, filters) and metadata_in_ranges(meta, ranges) and (
        size.admits(row))


def _candidate(row: Row[Any]) -> Candidate:
    size = None
    if row.size_length is not None:
        size = ShapeSize(*(getattr(row, f"size_{name}") for name in SIZE_FIELDS))
    return Candidate(row.index_id, row.id, row.external_id, row.name, row.meta, size, row.units)


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
    size: SizeQuery,
    ranges: Ranges,
) -> list[Match]:
    """Scan mode's ``find_similar``: the ``k`` models whose best entry is nearest, or, with
    the index's hub discount and no size term, the ``scan_depth(k)`` nearest re-ordered
    by scan mode's discount (``_scan_hub_order``)."""
    discounted = index.hub_neighbours > 0 and size.weight == 0
    depth = scan_order.scan_depth(k) if discounted else k
    filtered = bool(filters) or bool(ranges) or size.filters
    if discounted:
        answer = _scan_hub_answer(index, connection, key, vector, k, depth, min_score,
                                  exclude, allowed,
                                  lambda row: _passes(row, filters, ranges, size),
                                  screen=filtered and allowed is None)
        if answer is not None:
            return answer
    sizes = _partition_sizes(index, key)
    per_model = _views_per_model(sizes)
    fetch = (depth + 1 if exclude is not None else depth) * (
        4 if filtered and allowed is None else 1)
    # Estimated distances in either partition: a margin of candidates.
    fetch = max(index.rerank_candidates(key, fetch), index.rerank_candidates(views_key(key), fetch))
    matches: dict[int, Match] = {}
    entries: dict[int, np.ndarray] = {}
    seen: set[int] = set()
    while True:
        wanted = (fetch, fetch * per_model)
        model_hits = index.search(key, vector, wanted[0], allowed=allowed)
        view_hits = index.search_views(key, vector, wanted[1], allowed=allowed)
        found = [i for i, _ in model_hits] + [i for i, _, _ in view_hits]
        fresh = [i for i in dict.fromkeys(found) if i not in seen and i != exclude]
        seen.update(found)
        for row, distance, view, rows in _confirmed_best(connection, index, key, fresh, vector):
            if _passes(row, filters, ranges, size):
                distance = size.distance(distance, row)
                matches[row.index_id] = Match(_candidate(row), distance, score_of(distance), view)
                entries[row.index_id] = rows
        bound = _certainty_bound(model_hits, view_hits, wanted, sizes)
        ranked = sorted(matches.values(), key=lambda m: (m.distance, m.model.index_id))
        if min_score is not None:
            ranked = [m for m in ranked if m.score >= min_score]
        # Exact distances against the index's float32 ones: allow for rounding.
        certain = [m for m in ranked if m.distance <= bound + 1e-5]
        past_min = min_score is not None and score_of(bound) < min_score
        if len(certain) >= depth or bound == float("inf") or past_min:
            break
        fetch *= 4
    if not discounted:
        return certain[:k]
    by_id = {m.model.index_id: m for m in certain[:depth]}

    def join(first: int) -> dict[int, np.ndarray]:
        """The first answer's nearest models that qualify, with their entries."""
        near = _nearest_wholes(index, key, entries[first][0], {first, exclude}, allowed,
                               filtered and allowed is None)
        confirmed = {found[0].index_id: found for found in _confirmed_best(
            connection, index, key, [i for i in near if i not in by_id], vector)}
        # The nearest that pass the filters (the pool's do), as the pool holds the nearest
        # that pass.
        passing = [i for i in near if i in by_id or (
            i in confirmed and _passes(confirmed[i][0], filters, ranges, size))]
        joined: dict[int, np.ndarray] = {}
        for i in passing[: scan_order.ANCHOR_NEIGHBOURS]:
            if i in by_id:
                continue
            row, distance, view, rows = confirmed[i]
            if min_score is None or score_of(distance) >= min_score:
                by_id[i] = Match(_candidate(row), distance, score_of(distance), view)
                joined[i] = rows
        return joined

    order = _scan_hub_order(index, key, vector, list(by_id), entries, exclude, k, join)
    return [by_id[i] for i in order[:k]]


def _partition_sizes(index: ShapeIndex, key: PartitionKey) -> tuple[int, int]:
    """How many models partition ``key`` holds, and how many views its views partition."""
    return index.partition_size(key), index.partition_size(views_key(key))


def _views_per_model(sizes: tuple[int, int]) -> int:
    """Views per model on average (at least 1), from ``_partition_sizes``: a model's views
    tend to be near a query together, so a views search asks this many times more hits."""
    return max(1, -(-sizes[1] // max(sizes[0], 1)))


def _certainty_bound(model_hits: list[tuple[int, float]],
                     view_hits: list[tuple[int, int, float]], wanted: tuple[int, int],
                     sizes: tuple[int, int]) -> float:
    """No model not seen yet is nearer than the last hit of each partition not yet
    exhausted (inf when both are): matches up to this distance are certain."""
    bound = float("inf")
    hit_distances = ([d for _, d in model_hits], [d for _, _, d in view_hits])
    for hits, asked, held in zip(hit_distances, wanted, sizes, strict=True):
        if len(hits) == asked and asked < held:
            bound = min(bound, hits[-1])
    return bound


def _scan_hub_answer(
    index: ShapeIndex,
    connection: Connection,
    key: PartitionKey,
    vector: np.ndarray,
    k: int,
    depth: int,
    min_score: float | None,
    exclude: int | None,
    allowed: list[int] | None,
    passes: Callable[[Row[Any]], bool],
    screen: bool = False,
) -> list[Match] | None:
    """Scan mode's ``_hub_answer``: ordered from the index alone, then confirmed. Each
    model's distance is its nearest hit's or its descriptor's, exact from the index's
    vectors as added; the ``depth`` nearest certain models, all their entries read
    (``_index_entries``), go in scan mode's order (``_scan_hub_order``); the database
    confirms them in that order, as many as the answer takes. So a query reads each hit's
    vector, the pool's entries, the joined models' descriptors (their views only for the
    answered, or for all with ``min_score``) and about ``k`` rows, where confirming every
    candidate first read every entry of seven models or so per model of the pool (12 KB an
    entry): 3.2-3.7x a plain search at a pool of 40, 2.2-2.4x now (``bench/scan_search.py``).
    None when the first answer (which orders the rest) or fewer than ``k`` were confirmed
    while models beyond the pool may qualify: ``_best_entries``' general search, which
    confirms every candidate, answers instead.

    A model is certain when its nearest hit is no farther than the last hit of each
    partition not exhausted: an entry of it that was no hit is then no nearer (to within an
    approximate partition's estimates, as in the general search).

    ``screen``: filters that SQL could not narrow to ids (too many models pass them). The
    certain models' rows are then read nearest first, a few at a time, until ``depth`` of
    them pass: the pool holds models that pass, and its rows are the answer's, where the
    general search read every entry of four times the candidates (125 -> 31 ms for a filter
    three models in four pass, 2 x 10^4 models, ``bench/scan_search.py --filters``)."""
    sizes = _partition_sizes(index, key)
    per_model = _views_per_model(sizes)
    wanted_models = depth + 1 if exclude is not None else depth
    fetch = max(index.rerank_candidates(key, wanted_models),
                index.rerank_candidates(views_key(key), wanted_models))
    nearest_hit: dict[int, float] = {}  # model -> its nearest hit entry's exact distance
    measured: set[int] = set()  # the entries whose exact distances are in nearest_hit
    screened: dict[int, Row[Any] | None] = {}  # with screen: read rows (None: refused)
    while True:
        wanted = (fetch, fetch * per_model)
        model_hits = index.search(key, vector, wanted[0], allowed=allowed)
        view_hits = index.search_views(key, vector, wanted[1], allowed=allowed)
        # Each hit, and each model's own descriptor: an approximate partition may miss a
        # model's descriptor whose view it finds (its best entry then read all the same).
        hits = [(i, i) for i, _ in model_hits] + [
            entry for i, v, _ in view_hits for entry in ((view_id(i, v), i), (i, i))]
        fresh = [(entry, model) for entry, model in dict(hits).items()
                 if entry not in measured and model != exclude]
        measured.update(entry for entry, _ in hits)
        for model, distance in _entry_distances(index, key, vector, fresh):
            nearest_hit[model] = min(distance, nearest_hit.get(model, float("inf")))
        bound = _certainty_bound(model_hits, view_hits, wanted, sizes)
        ranked = sorted(nearest_hit, key=lambda i: (nearest_hit[i], i))
        if min_score is not None:
            ranked = [i for i in ranked if score_of(nearest_hit[i]) >= min_score]
        # Exact distances against the index's float32 ones: allow for rounding.
        certain = [i for i in ranked if nearest_hit[i] <= bound + 1e-5]
        if screen:
            certain = _screened(connection, key[0], certain, screened, passes, depth)
        past_min = min_score is not None and score_of(bound) < min_score
        if len(certain) >= depth or bound == float("inf") or past_min:
            break
        fetch *= 4
    entries = _index_entries(index, key, certain[:depth])
    # model -> its best entry's distance and view
    best = _best_of_each(entries, vector)

    def join(first: int) -> dict[int, np.ndarray]:
        """The first answer's nearest models that qualify, with their descriptors (or all
        their entries, when ``min_score`` needs each one's best)."""
        near = _nearest_wholes(index, key, entries[first][0], {first, exclude}, allowed,
                               screen)
        if screen:  # the nearest that pass, as the pool holds the nearest that pass
            near = _screened(connection, key[0], near, screened, passes,
                             scan_order.ANCHOR_NEIGHBOURS)
        fresh = [i for i in near if i not in entries]
        if min_score is None:
            # The order needs only their descriptors; the views of the few answered are
            # read below, for their best entry.
            return _index_wholes(index, key, fresh)
        joined = _index_entries(index, key, fresh)
        best.update(_best_of_each(joined, vector))
        return {i: stacked for i, stacked in joined.items()
                if score_of(best[i][0]) >= min_score}

    order = _scan_hub_order(index, key, vector, sorted(best, key=lambda i: (best[i][0], i)),
                            entries, exclude, k, join)
    matches: list[Match] = []
    for start in range(0, len(order), k):
        chunk = order[start : start + k]
        best.update(_best_of_each(
            _index_entries(index, key, [i for i in chunk if i not in best]), vector))
        chunk = [i for i in chunk if i in best]  # a joined model replaced meanwhile: out
        read = ([screened[i] for i in chunk] if screen
                else _ready_candidates(connection, key[0], chunk))
        rows = {row.index_id: row for row in read if row is not None and passes(row)}
        if start == 0 and order[0] not in rows:
            return None
        matches += [Match(_candidate(rows[i]), best[i][0], score_of(best[i][0]), best[i][1])
                    for i in chunk if i in rows]
        if len(matches) >= k:
            return matches[:k]
    beyond = len(certain) > depth or (bound < float("inf") and not past_min)
    return None if beyond else matches


def _nearest_wholes(index: ShapeIndex, key: PartitionKey, anchor: np.ndarray,
                    skip: set[int | None], allowed: list[int] | None, screen: bool
                    ) -> list[int]:
    """The models of partition ``key`` nearest ``anchor`` (a model's whole descriptor),
    nearest first, up to ``core.scan_order.ANCHOR_NEIGHBOURS`` of them (four times as many
    with ``screen``, for the filters to pick from), without ``skip``; among ``allowed``
    when given. By the index's own distances: a compressed partition's estimates, not
    re-ranked (which would read twice the vectors): who joins at the edge matters little,
    and the joined are ordered from their exact vectors."""
    wanted = scan_order.ANCHOR_NEIGHBOURS * (4 if screen else 1)
    if wanted == 0:
        return []
    hits = index.search(key, anchor, wanted + len(skip), allowed=allowed)
    return [i for i, _ in hits if i not in skip][:wanted]


def _entry_distances(index: ShapeIndex, key: PartitionKey, vector: np.ndarray,
                     entries: list[tuple[int, int]]) -> list[tuple[int, float]]:
    """``(model, exact distance)`` of each ``(entry id, model)`` of ``entries`` that
    partition ``key`` (a model's descriptor) or its views (a ``view_id``) still holds."""
    out: list[tuple[int, float]] = []
    for partition, ids in ((key, [e for e in entries if e[0] < VIEW_ID_BASE]),
                           (views_key(key), [e for e in entries if e[0] >= VIEW_ID_BASE])):
        distances = _exact_distances(index, partition, [entry for entry, _ in ids], vector)
        out += [(model, distances[entry]) for entry, model in ids if entry in distances]
    return out


def _index_wholes(index: ShapeIndex, key: PartitionKey, ids: list[int]
                  ) -> dict[int, np.ndarray]:
    """The descriptor of each of ``ids`` as partition ``key`` holds it (as added), ``(1, d)
    float32``: ``_index_entries`` without the views. An id the index no longer holds is
    left out."""
    found = index.exact_vectors(key, ids) if ids else None
    if found is None:
        return {}
    wholes, held = found
    return {i: whole[None] for i, whole, is_held in zip(ids, wholes, held.tolist(), strict=True)
            if is_held}


def _index_entries(index: ShapeIndex, key: PartitionKey, ids: list[int]
                   ) -> dict[int, np.ndarray]:
    """The entries of each of ``ids`` as partition ``key`` and its views hold them (as
    added): ``(1 + v, d) float32``, the model's descriptor first, its views ``0 .. v - 1``
    after it (up to the first the index no longer holds: replaced a moment ago). An id
    whose descriptor the index no longer holds is left out."""
    wholes = _index_wholes(index, key, ids)
    counts = {index_id: index.views_held(index_id) for index_id in wholes}
    viewed = index.exact_vectors(views_key(key), [
        view_id(i, v) for i, count in counts.items() for v in range(count)])
    entries = {}
    start = 0
    for index_id, count in counts.items():
        rows, start = slice(start, start + count), start + count
        if viewed is not None:
            count = int(np.cumprod(viewed[1][rows]).sum())  # held views before a gap
        views = viewed[0][rows][:count] if viewed is not None else wholes[index_id][:0]
        entries[index_id] = np.concatenate([wholes[index_id], views])
    return entries


#: The pool's models nearest by best entry whose entries bound every entry's radius in scan
#: mode's order (``model_radii_among``): the bound costs entries times theirs, and the
#: nearest are the ones that bound it most.
RADIUS_BOUND_MODELS = 40


def _scan_hub_order(
    index: ShapeIndex,
    key: PartitionKey,
    vector: np.ndarray,
    ids: list[int],
    entries: dict[int, np.ndarray],
    exclude: int | None,
    k: int,
    join: Callable[[int], dict[int, np.ndarray]],
) -> list[int]:
    """``ids`` (the pool, nearest by best entry first) in scan mode's order
    (``core.scan_order``), from their ``entries`` (``(1 + v, d) float32``, the model's
    descriptor first, its views in order after it); the first alone for ``k`` 1: first
    the model of least hub key (``core.hubness.model_radii``: a model's key is the least
    ``|q - e|^2 + SCAN_HUB_WEIGHT r(e)`` over its entries ``e``, ``r(e)`` the mean over the
    ``SCAN_HUB_NEIGHBOURS`` other models most alike ``e`` (not the query model ``exclude``)
    of ``e``'s largest cosine to their entries), then the others joined with the first
    answer's nearest models, ``join(first)`` (id -> entries, as ``entries``), in the order a
    shape query for that first answer's whole descriptor gives them (``_hub_order``: the hub
    discount and the k-reciprocal re-rank among them). Ties in upload order.

    An entry's radius costs a search, so entries are taken best bound first: each starts
    at the key its radius among the candidates gives (``model_radii_among``, a lower bound),
    and gets its searched radius only when it comes first; a model whose best entry comes
    first with its searched key is placed. The first answer is the one every radius would
    give, at a few searches rather than one per entry.
    """
    if not ids:
        return ids
    stacked = np.concatenate([entries[i] for i in ids]).astype(np.float32)
    owners = np.repeat(ids, [len(entries[i]) for i in ids])
    # A model's whole descriptor is entry index_id, its view v entry view_id(index_id, v).
    entry_ids = [e for i in ids for e in (i, *(view_id(i, v) for v in range(len(entries[i]) - 1)))]
    as_float64 = stacked.astype(np.float64)
    squared = np.sum((as_float64 - vector) ** 2, axis=1)
    # Keys start from each entry's radius among the nearest models' entries (cheap), take
    # the bound among the whole pool's when they come first (the bound an approximate
    # partition's searched radius is held to), then their searched radius.
    bounds = model_radii_among(as_float64, owners, SCAN_HUB_NEIGHBOURS,
                               among=np.isin(owners, ids[:RADIUS_BOUND_MODELS]))
    radii = bounds.copy()
    searched, near_bound = 0, 2  # what an entry's key rests on (1: the pool's bound)
    # The query's own descriptor: its key does not depend on a radius.
    stage = np.where(squared <= SAME_DESCRIPTOR**2, searched, near_bound)
    heap = list(zip(hub_keys(squared, radii, SCAN_HUB_WEIGHT).tolist(), stage.tolist(),
                    owners.tolist(), range(len(owners)), strict=True))
    heapq.heapify(heap)
    while True:
        _, rests_on, first, entry = heapq.heappop(heap)
        if rests_on == searched:
            break
        if rests_on == near_bound:
            bounds[entry] = model_radii_among(as_float64, owners, SCAN_HUB_NEIGHBOURS,
                                              rows=np.array([entry]))[0]
            radii[entry] = bounds[entry]
        else:
            radius = _entry_radii(index, key, stacked[entry : entry + 1], [entry_ids[entry]],
                                  owners[entry : entry + 1], exclude)[0]
            # An approximate partition's radius may fall below the bound exact vectors give.
            radii[entry] = max(radius, float(bounds[entry]))
        heapq.heappush(heap, (float(hub_keys(squared[entry], radii[entry], SCAN_HUB_WEIGHT)),
                              rests_on - 1, first, entry))
    if k == 1:
        return [first]
    joined = join(first)
    pool = set(ids)
    rest = [i for i in ids if i != first] + [i for i in joined if i not in pool]
    if not rest:
        return [first]
    # The first answer's whole descriptor (a model's first entry) queries the rest as shape
    # mode would: plain distances from it, its vectors already read.
    anchor = entries[first][0].astype(np.float64)
    whole = {i: (entries[i] if i in entries else joined[i])[0] for i in rest}
    rows = np.array([whole[i] for i in rest], dtype=np.float64)
    distances = np.sqrt(np.sum((rows - anchor) ** 2, axis=1)).tolist()
    return [first, *_hub_order(index, key, rest, distances, exclude, query=anchor, read=whole)]


def _entry_radii(
    index: ShapeIndex,
    key: PartitionKey,
    stacked: np.ndarray,
    entry_ids: list[int],
    owners: np.ndarray,
    exclude: int | None,
) -> np.ndarray:
    """``r(e)`` of each row of ``stacked : (e, d) float32``, the entries ``entry_ids`` of
    the models ``owners : (e,) int``, from the index's entry neighbours
    (``ShapeIndex.entry_neighbours``), without the query model ``exclude``."""
    models, cosines = index.entry_neighbours(key, entry_ids, owners.tolist(), stacked)
    if exclude is not None:
        models = np.where(models == exclude, -1, models)
    return model_radii(cosines, models, SCAN_HUB_NEIGHBOURS)


def _confirmed_best(
    connection: Connection, index: ShapeIndex, key: PartitionKey, ids: list[int],
    query: np.ndarray,
) -> list[tuple[Row[Any], float, int | None, np.ndarray]]:
    """The candidates still ready in the database, each with the exact distance of its
    best entry, which one it is (None: the model) and its entries ``(1 + views, d)
    float32``, the model's descriptor first, as the index holds them (``_index_entries``)."""
    held = _index_entries(index, key, ids)
    best = _best_of_each(held, query)
    return [(row, *best[row.index_id], held[row.index_id])
            for row in _ready_candidates(connection, key[0], list(held))]


def _best_of_each(entries: dict[int, np.ndarray], query: np.ndarray
                  ) -> dict[int, tuple[float, int | None]]:
    """The distance from ``query`` of the nearest of each model's ``entries`` (id ->
    ``(1 + v, d)``, its descriptor first) and which it is: None for the model's descriptor,
    else its view. One pass over every model's entries, not a call per model."""
    if not entries:
        return {}
    counts = [len(rows) for rows in entries.values()]
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).tolist()
    distances = np.linalg.norm(np.concatenate(list(entries.values())) - query, axis=1)
    nearest = [start + int(np.argmin(distances[start : start + count]))
               for start, count in zip(starts, counts, strict=True)]
    return {model: (float(distances[at]), None if at == start else at - start - 1)
            for model, at, start in zip(entries, nearest, starts, strict=True)}
