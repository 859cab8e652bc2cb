"""Shape mode: the nearest whole models, ordered by the hub discount and the k-reciprocal
re-rank (the package's docstring tells the order and why)."""

from __future__ import annotations

from typing import Any

import numpy as np
from sqlalchemy import Connection, Row

from app.search.index import PartitionKey, ShapeIndex
from app.search.similarity._orders import ORDERS
from app.search.similarity._query import Query
from app.search.similarity._rows import (
    Match,
    candidate_of,
    first_passing,
    ready_candidates,
    score_of,
    without_query,
)
from core.rank.hubness import hub_keys, rerank_depth
from core.rank.reciprocal import pool_keys, reciprocal_depth


def shape_matches(
    index: ShapeIndex, connection: Connection, key: PartitionKey, query: Query
) -> list[Match]:
    """Shape mode's ``find_similar``: the ``k`` nearest models, or, with the index's hub
    discount, the nearest re-ordered by it (``hub_answer``, from the index alone, or this
    general search when that cannot answer) and re-ranked k-reciprocally."""
    vector, k, min_score, size = query.vector, query.k, query.min_score, query.size
    exclude, allowed = query.exclude, query.allowed
    approximate = index.is_approximate(key)
    discounted = index.hub_neighbours > 0
    # Plain nearest, re-ordered below; a k-reciprocal re-rank takes neighbourhoods among them
    # (not with a size term: its combined distances are no vectors' distances).
    reciprocal = discounted and index.reciprocal and size.weight == 0
    depth = reciprocal_depth(k) if reciprocal else rerank_depth(k) if discounted else k
    wanted = depth + 1 if exclude is not None else depth
    fetch = index.rerank_candidates(key, wanted)
    if query.screen:
        fetch *= 4
    if discounted and size.weight == 0:
        answer = hub_answer(index, connection, key, query, depth, fetch)
        if answer is not None:
            return answer
    matches: list[Match] = []
    seen: set[int] = set()
    query_id = exclude if query.indexed_query else None
    while True:
        hits = index.search(key, vector, fetch, allowed=allowed)
        fresh = [i for i, _ in hits if i not in seen and i != exclude]
        seen.update(i for i, _ in hits)
        if query_id is None:
            rows = ready_candidates(connection, key[0], fresh)
        else:  # the query model's own row rides along, once
            rows = ready_candidates(connection, key[0], [*fresh, query_id], "descriptor_version")
            rows = without_query(rows, query_id, key)
            query_id = None
        distances = dict(hits)
        if approximate:  # estimates from the codes: exact ones from the full vectors
            distances.update(exact_distances(index, key, [row.index_id for row in rows], vector))
        for row in rows:
            if query.passes(row):
                distance = size.distance(distances[row.index_id], row)
                matches.append(Match(candidate_of(row), distance, score_of(distance)))
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
            return hub_ordered(index, key, nearest, exclude,
                               vector if reciprocal else None)[:k]
        fetch *= 4


def hub_answer(
    index: ShapeIndex, connection: Connection, key: PartitionKey, query: Query, depth: int,
    fetch: int,
) -> list[Match] | None:
    """``find_similar`` with the hub discount, without a size term, unfiltered or with the
    ids that pass the filters ``query.allowed`` by SQL: the ``depth`` nearest (exact distances)
    are ordered from the index alone, then confirmed by the database in that order, as
    many as the answer takes, so the database reads about ``k`` rows, not ``depth``. None
    when fewer than ``k`` were confirmed (deleted a moment ago, or refused by the filters,
    which SQL can let through) while models beyond the ``depth`` nearest may qualify: the
    caller's general search widens instead. A k-reciprocal re-rank takes its neighbourhoods
    among the ``depth`` nearest that SQL allowed, a row the filters then refuse included.

    ``query.screen``: filters SQL could not narrow to ids. The hits' rows are read nearest first
    until ``depth`` of them pass (``first_passing``), and those are the ones ordered."""
    k, min_score = query.k, query.min_score
    allowed, passes, screen = query.allowed, query.passes, query.screen
    query_id = query.exclude if query.indexed_query else None  # its row is confirmed with the rest
    screened: dict[int, Row[Any] | None] = {}  # with screen: read rows (None: refused)
    # A query model's order without filters or min_score, as computed before (``_orders``).
    stamp = index.stamp(key) if (query_id is not None and allowed is None and not screen
                                 and min_score is None) else None
    memo = None if stamp is None else (*stamp, query_id, depth, fetch)
    kept = None if memo is None else ORDERS.get(memo)
    if kept is not None:
        order = kept.order.tolist()
        distances = dict(zip(order, kept.distances.tolist(), strict=True))
        beyond = kept.beyond
    else:
        order, distances, beyond = _hub_pool(index, connection, key, query, depth, fetch,
                                             screened)
        if memo is not None and index.stamp(key) == stamp:  # unchanged meanwhile
            ORDERS.put(memo, order, [distances[i] for i in order], beyond)
    if screen and query_id is not None:  # the query model's own row, confirmed alone
        without_query(ready_candidates(connection, key[0], [query_id], "descriptor_version"),
                      query_id, key)
        query_id = None
    matches: list[Match] = []
    for start in range(0, max(len(order), 1), k):
        chunk = order[start : start + k]
        if screen:
            rows = [row for row in (screened[i] for i in chunk) if row is not None]
        elif query_id is None:
            rows = ready_candidates(connection, key[0], chunk)
        else:  # the query model's own row rides along, once
            rows = without_query(ready_candidates(connection, key[0], [*chunk, query_id],
                                                  "descriptor_version"), query_id, key)
            query_id = None
        by_id = {row.index_id: row for row in rows if passes(row)}
        matches += [Match(candidate_of(by_id[i]), distances[i], score_of(distances[i]))
                    for i in chunk if i in by_id]
        if len(matches) >= k:
            return matches[:k]
    return None if beyond else matches


def _hub_pool(
    index: ShapeIndex, connection: Connection, key: PartitionKey, query: Query, depth: int,
    fetch: int, screened: dict[int, Row[Any] | None],
) -> tuple[list[int], dict[int, float], bool]:
    """``hub_answer``'s candidates in the order the answer takes them, their plain distances
    by id, and whether models beyond them may qualify (``screened``: the rows read, with
    ``query.screen``)."""
    vector, min_score = query.vector, query.min_score
    exclude, allowed, passes, screen = query.exclude, query.allowed, query.passes, query.screen
    # The full vectors read for exact distances, kept only for a k-reciprocal re-rank.
    read: dict[int, np.ndarray] | None = {} if index.reciprocal else None
    while True:
        hits = index.search(key, vector, fetch, allowed=allowed)
        ids = [i for i, _ in hits if i != exclude]
        exhausted = len(hits) < fetch or fetch >= index.partition_size(key)
        distances = dict(hits)
        if index.is_approximate(key):  # estimates from the codes: exact ones, full vectors
            distances.update(exact_distances(index, key, ids, vector, read))
        ranked = sorted(ids, key=lambda i: (distances[i], i))
        if screen:
            ranked = first_passing(connection, key[0], ranked, screened, passes, depth)
        if len(ranked) >= depth or exhausted:
            break
        fetch *= 4
    nearest = ranked[:depth]
    beyond = len(ids) > depth or not exhausted  # more candidates than those ordered here
    if min_score is not None:
        qualifying = [i for i in nearest if score_of(distances[i]) >= min_score]
        beyond = beyond and len(qualifying) == len(nearest)
        nearest = qualifying
    # A query by model id is that model's own vector, at plain distances here.
    order = hub_order(index, key, nearest, [distances[i] for i in nearest], exclude,
                      query_is_excluded=True, query=vector, read=read)
    return order, distances, beyond

def hub_order(index: ShapeIndex, key: PartitionKey, ids: list[int], distances: list[float],
              exclude: int | None, query_is_excluded: bool = False,
              query: np.ndarray | None = None,
              read: dict[int, np.ndarray] | None = None) -> list[int]:
    """``ids`` (nearest first, at plain ``distances``, or combined ones with a size term) in
    the order of the hub discount (``core.rank.hubness.hub_keys``), the query model ``exclude``
    in no neighbourhood (``query_is_excluded``: the query vector is its own and the
    distances plain, so its cosines are known); ties in upload order. An id the index
    dropped since it was found (deleted a moment ago) takes the largest radius among the
    others. With the index's ``reciprocal`` and the ``query`` vector (plain distances),
    that order is re-ranked k-reciprocally among ``ids`` (``reciprocal_keys``; ``read``:
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
        keys = reciprocal_keys(index, key, ids, keys, query, read or {})
    return [ids[j] for j in sorted(range(len(ids)), key=lambda j: (keys[j], ids[j]))]


def reciprocal_keys(index: ShapeIndex, key: PartitionKey, ids: list[int], hub: np.ndarray,
                    query: np.ndarray, read: dict[int, np.ndarray]) -> np.ndarray:
    """``core.rank.reciprocal.pool_keys`` of ``ids`` for ``query`` (their ``hub`` keys as its
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


def hub_ordered(
    index: ShapeIndex, key: PartitionKey, matches: list[Match], exclude: int | None,
    query: np.ndarray | None,
) -> list[Match]:
    """``matches`` (nearest first) re-ordered by the hub discount (``hub_order``), and
    k-reciprocally with the ``query`` vector."""
    by_id = {m.model.index_id: m for m in matches}
    order = hub_order(index, key, list(by_id), [m.distance for m in matches], exclude,
                      query=query)
    return [by_id[i] for i in order]


def exact_distances(
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

