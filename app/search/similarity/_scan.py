"""Scan mode: each model at its best entry (its descriptor or one of its virtual views),
ordered by scan mode's own discount and its first answer's shape query (the package's
docstring tells the order and why)."""

from __future__ import annotations

import heapq
from collections.abc import Callable
from typing import Any

import numpy as np
from sqlalchemy import Connection, Row

from app.search.index import VIEW_ID_BASE, PartitionKey, ShapeIndex, view_id, views_key
from app.search.similarity._query import Query
from app.search.similarity._rows import (
    Match,
    candidate_of,
    first_passing,
    ready_candidates,
    score_of,
)
from app.search.similarity._shape import exact_distances, hub_order
from core.rank import scan_order
from core.rank.hubness import (
    SAME_DESCRIPTOR,
    SCAN_HUB_NEIGHBOURS,
    SCAN_HUB_WEIGHT,
    hub_keys,
    model_radii,
    model_radii_among,
)


def scan_matches(
    index: ShapeIndex, connection: Connection, key: PartitionKey, query: Query
) -> list[Match]:
    """Scan mode's ``find_similar``: the ``k`` models whose best entry is nearest, or, with
    the index's hub discount and no size term, the ``scan_depth(k)`` nearest re-ordered
    by scan mode's discount (``_scan_hub_order``)."""
    vector, k, min_score, size = query.vector, query.k, query.min_score, query.size
    exclude, allowed = query.exclude, query.allowed
    discounted = index.hub_neighbours > 0 and size.weight == 0
    depth = scan_order.scan_depth(k) if discounted else k
    if discounted:
        answer = _scan_hub_answer(index, connection, key, query, depth)
        if answer is not None:
            return answer
    sizes = _partition_sizes(index, key)
    per_model = _views_per_model(sizes)
    fetch = (depth + 1 if exclude is not None else depth) * (
        4 if query.screen else 1)
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
            if query.passes(row):
                distance = size.distance(distance, row)
                matches[row.index_id] = Match(candidate_of(row), distance, score_of(distance), view)
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
                               query.screen)
        confirmed = {found[0].index_id: found for found in _confirmed_best(
            connection, index, key, [i for i in near if i not in by_id], vector)}
        # The nearest that pass the filters (the pool's do), as the pool holds the nearest
        # that pass.
        passing = [i for i in near if i in by_id or (
            i in confirmed and query.passes(confirmed[i][0]))]
        joined: dict[int, np.ndarray] = {}
        for i in passing[: scan_order.ANCHOR_NEIGHBOURS]:
            if i in by_id:
                continue
            row, distance, view, rows = confirmed[i]
            if min_score is None or score_of(distance) >= min_score:
                by_id[i] = Match(candidate_of(row), distance, score_of(distance), view)
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
    index: ShapeIndex, connection: Connection, key: PartitionKey, query: Query, depth: int,
) -> list[Match] | None:
    """Scan mode's ``hub_answer``: ordered from the index alone, then confirmed. Each
    model's distance is its nearest hit's or its descriptor's, exact from the index's
    vectors as added; the ``depth`` nearest certain models, all their entries read
    (``_index_entries``), go in scan mode's order (``_scan_hub_order``); the database
    confirms them in that order, as many as the answer takes. So a query reads each hit's
    vector, the pool's entries, the joined models' descriptors (their views only for the
    answered, or for all with ``min_score``) and about ``k`` rows, where confirming every
    candidate first read every entry of seven models or so per model of the pool (12 KB an
    entry): 3.2-3.7x a plain search at a pool of 40, 2.2-2.4x now (``bench/scan_search.py``).
    None when the first answer (which orders the rest) or fewer than ``k`` were confirmed
    while models beyond the pool may qualify: ``scan_matches``' general search, which
    confirms every candidate, answers instead.

    A model is certain when its nearest hit is no farther than the last hit of each
    partition not exhausted: an entry of it that was no hit is then no nearer (to within an
    approximate partition's estimates, as in the general search).

    ``query.screen``: filters that SQL could not narrow to ids (too many models pass them).
    The certain models' rows are then read nearest first, a few at a time, until ``depth`` of
    them pass: the pool holds models that pass, and its rows are the answer's, where the
    general search read every entry of four times the candidates (125 -> 31 ms for a filter
    three models in four pass, 2 x 10^4 models, ``bench/scan_search.py --filters``)."""
    vector, k, min_score = query.vector, query.k, query.min_score
    exclude, allowed, passes, screen = query.exclude, query.allowed, query.passes, query.screen
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
            certain = first_passing(connection, key[0], certain, screened, passes, depth)
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
            near = first_passing(connection, key[0], near, screened, passes,
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
                else ready_candidates(connection, key[0], chunk))
        rows = {row.index_id: row for row in read if row is not None and passes(row)}
        if start == 0 and order[0] not in rows:
            return None
        matches += [Match(candidate_of(rows[i]), best[i][0], score_of(best[i][0]), best[i][1])
                    for i in chunk if i in rows]
        if len(matches) >= k:
            return matches[:k]
    beyond = len(certain) > depth or (bound < float("inf") and not past_min)
    return None if beyond else matches


def _nearest_wholes(index: ShapeIndex, key: PartitionKey, anchor: np.ndarray,
                    skip: set[int | None], allowed: list[int] | None, screen: bool
                    ) -> list[int]:
    """The models of partition ``key`` nearest ``anchor`` (a model's whole descriptor),
    nearest first, up to ``core.rank.scan_order.ANCHOR_NEIGHBOURS`` of them (four times as many
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
        distances = exact_distances(index, partition, [entry for entry, _ in ids], vector)
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
    (``core.rank.scan_order``), from their ``entries`` (``(1 + v, d) float32``, the model's
    descriptor first, its views in order after it); the first alone for ``k`` 1: first
    the model of least hub key (``core.rank.hubness.model_radii``: a model's key is the least
    ``|q - e|^2 + SCAN_HUB_WEIGHT r(e)`` over its entries ``e``, ``r(e)`` the mean over the
    ``SCAN_HUB_NEIGHBOURS`` other models most alike ``e`` (not the query model ``exclude``)
    of ``e``'s largest cosine to their entries), then the others joined with the first
    answer's nearest models, ``join(first)`` (id -> entries, as ``entries``), in the order a
    shape query for that first answer's whole descriptor gives them (``hub_order``: the hub
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
    return [first, *hub_order(index, key, rest, distances, exclude, query=anchor, read=whole)]


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
            for row in ready_candidates(connection, key[0], list(held))]


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
