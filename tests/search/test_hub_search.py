"""Similar answers ordered with the hub discount (``core.rank.hubness``) in the search service:
the index's radii against a direct count, the service's order against the discount computed
over the whole catalogue, the query model left out, the same part kept first, filters, and
the setting that turns it off."""

from __future__ import annotations

import threading
import time

import faiss
import numpy as np
import pytest
from sqlalchemy.orm import Session, sessionmaker

from app.search.index import ShapeIndex, _neighbours
from app.search.similarity import Match, find_similar
from core.rank.hubness import hub_keys, neighbourhood_radii, rerank_depth
from core.rank.reciprocal import pool_keys, reciprocal_depth
from tests.conftest import make_settings
from tests.core.test_hubness import direct_radius, hub_catalogue, unit_rows
from tests.search.test_index import add_ready, delete_model

KEY = ("t", "v1")


def hub_order(
    vectors: dict[int, np.ndarray],
    query: np.ndarray,
    k: int,
    neighbours: int,
    exclude: int | None = None,
    allowed: set[int] | None = None,
    reciprocal: bool = False,
) -> list[int]:
    """What the service should answer, computed directly: the plain nearest ``rerank_depth(k)``
    (among ``allowed``), re-ordered by ``hub_keys`` with radii over the whole catalogue,
    ``exclude`` neither a candidate nor in any radius; ``reciprocal``: the plain nearest
    ``reciprocal_depth(k)``, whose hub keys ``core.rank.reciprocal.pool_keys`` then re-ranks."""
    ids = [i for i in vectors if i != exclude]
    rows = np.array([vectors[i] for i in ids], dtype=np.float64)
    radii = neighbourhood_radii(rows, neighbours)
    candidates = [i for i in ids if allowed is None or i in allowed]
    squared = {i: float(np.sum((vectors[i] - query) ** 2)) for i in candidates}
    depth = reciprocal_depth(k) if reciprocal else rerank_depth(k)
    nearest = sorted(candidates, key=lambda i: (squared[i], i))[:depth]
    keys = hub_keys(np.array([squared[i] for i in nearest]),
                    np.array([radii[ids.index(i)] for i in nearest]))
    if reciprocal and len(nearest) > 1:
        keys = pool_keys(query, np.array([vectors[i] for i in nearest]), keys)
    order = sorted(range(len(nearest)), key=lambda j: (keys[j], nearest[j]))
    return [nearest[j] for j in order][:k]


def search(index: ShapeIndex, sessions: sessionmaker[Session], query: np.ndarray,
           **options: object) -> list[Match]:
    with sessions() as session:
        return find_similar(index, session.connection(), KEY, query, **options)  # type: ignore[arg-type]


def planted_hub_catalogue(sessions: sessionmaker[Session]) -> tuple[np.ndarray, list[int]]:
    """``tests.test_hubness.hub_catalogue`` without its query, as ready models: the query
    vector and the ids of the classmate, the hub and the hub's six near parts."""
    rows, _ = hub_catalogue()
    return rows[0].astype(np.float32), [add_ready(sessions, row) for row in rows[1:]]


def test_a_hub_the_plain_order_puts_first_comes_after_the_classmate(
    sessions: sessionmaker[Session],
) -> None:
    query, (classmate, hub, *_) = planted_hub_catalogue(sessions)
    plain = ShapeIndex(sessions, hub_neighbours=0)
    discounted = ShapeIndex(sessions, hub_neighbours=3)
    plain.rebuild()
    discounted.rebuild()
    assert [m.model.index_id for m in search(plain, sessions, query, k=2)] == [hub, classmate]
    answer = search(discounted, sessions, query, k=2)
    assert [m.model.index_id for m in answer] == [classmate, hub]
    # Scores stay the plain similarity: the hub's is the higher one, second in the answer.
    assert answer[1].score > answer[0].score
    assert answer[0].score == pytest.approx((1 + 0.80) / 2, abs=1e-6)


@pytest.mark.slow
@pytest.mark.parametrize("exact_max", [10**6, 20], ids=["flat", "ivf"])
@pytest.mark.parametrize("reciprocal", [False, True], ids=["hub", "reciprocal"])
def test_the_answer_is_the_discount_over_the_whole_catalogue(
    sessions: sessionmaker[Session], exact_max: int, reciprocal: bool
) -> None:
    rows = unit_rows(60, 8, seed=3).astype(np.float32)
    vectors = {add_ready(sessions, row): row for row in rows}
    # nprobe at least the lists of an IVF partition: its search is exact, so are its radii.
    index = ShapeIndex(sessions, exact_max=exact_max, nprobe=64, hub_neighbours=5,
                       reciprocal=reciprocal)
    index.rebuild()
    assert index.describe(KEY) == ("flat" if exact_max > 60 else "ivf-sq8")
    ids = list(vectors)
    radii = index.neighbourhood_radii(KEY, ids)
    assert [radii[i] for i in ids] == pytest.approx(
        [direct_radius(rows, x, None, 5) for x in range(60)], abs=1e-5)
    changed = 0
    for q in range(8):
        query = unit_rows(1, 8, seed=100 + q)[0].astype(np.float32)
        answer = [m.model.index_id for m in search(index, sessions, query, k=6)]
        assert answer == hub_order(vectors, query, 6, 5, reciprocal=reciprocal)
        plain = sorted(vectors, key=lambda i: (float(np.linalg.norm(vectors[i] - query)), i))
        changed += answer != plain[:6]
    assert changed > 0  # the discount does reorder these answers
    # The background pass (the neighbour graph) keeps every neighbourhood, the same as
    # the queries computed (one search each).
    kept = index._partitions[KEY].kept
    computed = {own: kept.get(own) for own in ids}
    kept.forget()
    assert index.keep_neighbourhoods() == 60
    for own, entry in computed.items():
        again = kept.get(own)
        assert entry is not None and again is not None
        assert (again.top, again.kth, again.after) == pytest.approx(
            (entry.top, entry.kth, entry.after), abs=1e-5)


@pytest.mark.parametrize("neighbours", [4, 10], ids=["kept", "counted"])
@pytest.mark.parametrize("reciprocal", [False, True], ids=["hub", "reciprocal"])
def test_a_query_model_is_in_no_neighbourhood_and_not_an_answer(
    sessions: sessionmaker[Session], neighbours: int, reciprocal: bool
) -> None:
    # 4 neighbours of 30 models: kept neighbourhoods, the query taken out by arithmetic;
    # 10 of the first 8: too few models to keep them, counted without the query.
    rows = unit_rows(30, 6, seed=5).astype(np.float32)
    vectors = {add_ready(sessions, row): row for row in rows[: 8 if neighbours == 10 else 30]}
    index = ShapeIndex(sessions, hub_neighbours=neighbours, reciprocal=reciprocal)
    index.rebuild()
    ids = list(vectors)
    for query_id in ids[:6]:
        answer = search(index, sessions, vectors[query_id], k=5, exclude=query_id,
                        indexed_query=True)
        assert [m.model.index_id for m in answer] == hub_order(
            vectors, vectors[query_id], 5, neighbours, exclude=query_id, reciprocal=reciprocal)
    if neighbours == 10:
        return
    # Radii without the query differ from those with it where it was a near neighbour.
    with_query = index.neighbourhood_radii(KEY, ids[1:])
    without = index.neighbourhood_radii(KEY, ids[1:], exclude=ids[0])
    assert any(without[i] < with_query[i] - 1e-6 for i in ids[1:])
    assert without == pytest.approx(
        {i: direct_radius(rows, x, 0, 4) for x, i in enumerate(ids) if x > 0}, abs=1e-5)


@pytest.mark.slow
@pytest.mark.parametrize("whole_pass", [False, True], ids=["by-queries", "by-a-pass"])
def test_kept_neighbourhoods_a_change_moves_are_forgotten(
    sessions: sessionmaker[Session], whole_pass: bool
) -> None:
    # Kept by the queries' own searches (a dict) or by the background pass (its table).
    rows = unit_rows(40, 6, seed=9).astype(np.float32)
    vectors = {add_ready(sessions, row): row for row in rows}
    index = ShapeIndex(sessions, hub_neighbours=4)
    index.rebuild()
    if whole_pass:
        assert index.keep_neighbourhoods() == 40
    queries = unit_rows(5, 6, seed=90).astype(np.float32)
    for query in queries:
        assert [m.model.index_id for m in search(index, sessions, query, k=5)] == hub_order(
            vectors, query, 5, 4)
    kept = index._partitions[KEY].kept
    before = {own for own in vectors if kept.get(own) is not None}
    assert len(before) >= 5  # kept for the next queries
    # New models next to the queries enter the neighbourhoods of the kept candidates, and
    # a removed one leaves those it was in.
    for query in queries:
        near = unit_rows(1, 6, seed=int(query[0] * 1000) % 997)[0] * 0.05 + query
        vector = (near / np.linalg.norm(near)).astype(np.float32)
        vectors[add_ready(sessions, vector)] = vector
    removed = sorted(before)[3]
    delete_model(sessions, removed)
    del vectors[removed]
    index.sync()
    # Those the changes moved are forgotten, the rest kept, and every kept one is what a
    # fresh count over the changed catalogue gives.
    ids = list(vectors)
    after = {own: entry for own in ids if (entry := kept.get(own)) is not None}
    assert 0 < len(after) < len(before)
    rows = np.array([vectors[i] for i in ids])
    for own, entry in after.items():
        x = ids.index(own)
        cosines = sorted((float(rows[x] @ rows[y]) for y in range(len(ids)) if y != x),
                         reverse=True)
        assert (entry.top, entry.kth, entry.after) == pytest.approx(
            (sum(cosines[:4]), cosines[3], cosines[4]), abs=1e-5)
    for query in queries:
        assert [m.model.index_id for m in search(index, sessions, query, k=5)] == hub_order(
            vectors, query, 5, 4)


def test_the_query_s_own_part_stays_first_even_as_a_hub(sessions: sessionmaker[Session]) -> None:
    _, (classmate, hub, *_) = planted_hub_catalogue(sessions)
    rows, _ = hub_catalogue()
    index = ShapeIndex(sessions, hub_neighbours=3)
    index.rebuild()
    # The hub's own file uploaded again: itself first, though its radius is the largest.
    answer = search(index, sessions, rows[2].astype(np.float32), k=3)
    assert answer[0].model.index_id == hub and answer[0].score == pytest.approx(1.0)


@pytest.mark.parametrize("reciprocal", [False, True], ids=["hub", "reciprocal"])
def test_filters_narrow_the_candidates_not_the_neighbourhoods(
    sessions: sessionmaker[Session], reciprocal: bool
) -> None:
    rows = unit_rows(40, 6, seed=7).astype(np.float32)
    vectors = {add_ready(sessions, row, meta={"even": str(x % 2 == 0)}): row
               for x, row in enumerate(rows)}
    index = ShapeIndex(sessions, hub_neighbours=5, reciprocal=reciprocal)
    index.rebuild()
    even = {i for x, i in enumerate(vectors) if x % 2 == 0}
    for pushdown_max in (0, 10_000):  # widening index results, and ids selected in SQL
        for q in range(4):
            query = unit_rows(1, 6, seed=50 + q)[0].astype(np.float32)
            answer = search(index, sessions, query, k=4, filters={"even": "True"},
                            pushdown_max=pushdown_max)
            assert [m.model.index_id for m in answer] == hub_order(
                vectors, query, 4, 5, allowed=even, reciprocal=reciprocal)
        # By model id: the query model is in no neighbourhood here either.
        for query_id in list(vectors)[:4]:
            answer = search(index, sessions, vectors[query_id], k=4, filters={"even": "True"},
                            pushdown_max=pushdown_max, exclude=query_id, indexed_query=True)
            assert [m.model.index_id for m in answer] == hub_order(
                vectors, vectors[query_id], 4, 5, exclude=query_id, allowed=even,
                reciprocal=reciprocal)


@pytest.mark.parametrize("reciprocal", [False, True], ids=["hub", "reciprocal"])
def test_rows_sql_lets_through_and_the_filter_refuses_are_replaced_from_further_out(
    sessions: sessionmaker[Session], reciprocal: bool
) -> None:
    # On SQLite the metadata entry 1 stands for both 1 and true, so SQL selects the ten
    # models nearest the query and the filter then refuses them all: the answer must come
    # from beyond the 4 k nearest that SQL allowed.
    query = unit_rows(1, 6, seed=60)[0].astype(np.float32)
    near = unit_rows(10, 6, seed=61) * 0.05 + query
    near = (near / np.linalg.norm(near, axis=1, keepdims=True)).astype(np.float32)
    refused = [add_ready(sessions, row, meta={"flag": 1}) for row in near]
    far = unit_rows(20, 6, seed=62).astype(np.float32)
    vectors = {i: row for i, row in zip(refused, near, strict=True)}
    wanted = {add_ready(sessions, row, meta={"flag": True}): row for row in far}
    vectors.update(wanted)
    index = ShapeIndex(sessions, hub_neighbours=4, reciprocal=reciprocal)
    index.rebuild()
    answer = search(index, sessions, query, k=3, filters={"flag": "true"})
    if not reciprocal:
        assert [m.model.index_id for m in answer] == hub_order(
            vectors, query, 3, 4, allowed=set(wanted))
        return
    # The neighbourhoods of a k-reciprocal re-rank are taken among the candidates SQL
    # allowed (on SQLite the refused rows too: they count in them, and are not answers).
    with sessions() as session:
        sqlite = session.get_bind().dialect.name == "sqlite"
    allowed = set(vectors) if sqlite else set(wanted)
    order = hub_order(vectors, query, len(vectors), 4, allowed=allowed, reciprocal=True)
    assert [m.model.index_id for m in answer] == [i for i in order if i in wanted][:3]


def test_too_few_models_for_a_neighbourhood_answer_in_plain_order(
    sessions: sessionmaker[Session],
) -> None:
    only = add_ready(sessions, unit_rows(1, 4, seed=0)[0].astype(np.float32))
    index = ShapeIndex(sessions)
    index.rebuild()
    assert index.neighbourhood_radii(KEY, [only]) == {}  # no other model
    assert [m.model.index_id for m in search(index, sessions, unit_rows(1, 4, 1)[0], k=3)] == [only]


def test_the_setting_reaches_the_index_and_zero_turns_the_discount_off(
    database_url: str,
) -> None:
    assert make_settings(database_url).index_options["hub_neighbours"] == 10
    assert make_settings(database_url, search_hub_neighbours=0).index_options[
        "hub_neighbours"] == 0
    assert make_settings(database_url).index_options["reciprocal"] is True
    assert make_settings(database_url, search_reciprocal=False).index_options[
        "reciprocal"] is False


@pytest.mark.slow
def test_the_reciprocal_re_rank_takes_its_pool_from_the_plain_nearest(
    sessions: sessionmaker[Session],
) -> None:
    # 220 models: more than the pool (40), so the pool is the plain nearest 40, and the
    # answers differ from the hub discount's alone.
    rows = unit_rows(220, 8, seed=12).astype(np.float32)
    vectors = {add_ready(sessions, row): row for row in rows}
    index = ShapeIndex(sessions, hub_neighbours=10, reciprocal=True)
    index.rebuild()
    assert len(vectors) > reciprocal_depth(10)
    differs = 0
    for q in range(6):
        query = unit_rows(1, 8, seed=300 + q)[0].astype(np.float32)
        answer = [m.model.index_id for m in search(index, sessions, query, k=10)]
        assert answer == hub_order(vectors, query, 10, 10, reciprocal=True)
        differs += answer != hub_order(vectors, query, 10, 10)
    assert differs > 0


def test_a_bulk_change_forgets_every_neighbourhood_and_the_index_wants_them_again(
    sessions: sessionmaker[Session],
) -> None:
    rows = unit_rows(110, 6, seed=11).astype(np.float32)
    for row in rows[:40]:
        add_ready(sessions, row)
    index = ShapeIndex(sessions, hub_neighbours=4)
    index.rebuild()
    assert index.wants_neighbourhoods()  # none kept yet
    assert index.neighbourhoods_kept() == 0.0
    assert index.keep_neighbourhoods() == 40
    assert not index.wants_neighbourhoods() and index.neighbourhoods_kept() == 1.0
    for row in rows[40:]:  # 70 models in one sync: more than a change forgets one by one
        add_ready(sessions, row)
    assert index.sync() == 70
    assert len(index._partitions[KEY].kept) == 0 and index.neighbourhoods_kept() == 0.0
    assert index.wants_neighbourhoods()
    assert index.keep_neighbourhoods() == 110 and not index.wants_neighbourhoods()
    # Too few models to keep any: a pass finds nothing to do, and is not wanted again.
    small = ShapeIndex(sessions, hub_neighbours=200)
    small.rebuild()
    assert small.wants_neighbourhoods() is False and small.keep_neighbourhoods() == 0
    assert small.neighbourhoods_kept() == 1.0  # nothing it could keep is missing


@pytest.mark.slow
def test_a_pass_computes_only_the_blocks_whose_neighbourhoods_are_not_kept(
    sessions: sessionmaker[Session], monkeypatch: pytest.MonkeyPatch,
) -> None:
    rows = unit_rows(400, 6, seed=21).astype(np.float32)
    ids = [add_ready(sessions, row) for row in rows[:399]]
    index = ShapeIndex(sessions, hub_neighbours=4, exact_max=100)
    index.rebuild()
    partition = index._partitions[KEY]
    assert partition.approximate  # one block per inverted list
    invlists = faiss.extract_index_ivf(partition.index).invlists
    lists = sum(invlists.list_size(number) > 0 for number in range(invlists.nlist))
    kept = partition.kept
    computed: list[int] = []
    nearest = _neighbours._nearest
    stop_after = lists * 3 // 4  # more than half kept when it stops
    stopped = False

    def counted(*args: object) -> tuple[np.ndarray, np.ndarray]:
        nonlocal stopped
        computed.append(1)
        if len(computed) == stop_after and not stopped:
            kept.version += 1  # as a change after this block: the pass stops
            stopped = True
        return nearest(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(_neighbours, "_nearest", counted)
    assert len(ids) / 2 < index.keep_neighbourhoods() < len(ids)
    assert len(computed) == stop_after
    assert index.wants_neighbourhoods()  # a stopped pass is wanted again, however far it got
    assert 0.5 < index.neighbourhoods_kept() < 1.0
    computed.clear()
    assert index.keep_neighbourhoods() == len(ids)
    assert len(computed) == lists - stop_after  # it went on where the stopped one ended
    assert not index.wants_neighbourhoods()
    ids.append(add_ready(sessions, rows[399]))
    assert index.sync() == 1  # forgets its own neighbourhood and those it enters
    assert not index.wants_neighbourhoods()  # those few are left to the queries
    computed.clear()
    assert index.keep_neighbourhoods() == len(ids)
    assert 0 < len(computed) < lists / 2
    # What the passes kept piecewise is what one pass keeps from nothing.
    piecewise = {own: kept.get(own) for own in ids}
    kept.forget()
    assert index.keep_neighbourhoods() == len(ids)
    for own, entry in piecewise.items():
        whole = kept.get(own)
        assert entry is not None and whole is not None
        assert (entry.top, entry.kth, entry.after) == pytest.approx(
            (whole.top, whole.kth, whole.after), abs=1e-6)


@pytest.mark.slow
def test_blocks_of_a_lists_rows_keep_what_whole_lists_keep(
    sessions: sessionmaker[Session], monkeypatch: pytest.MonkeyPatch,
) -> None:
    rows = unit_rows(400, 6, seed=23).astype(np.float32)
    ids = [add_ready(sessions, row) for row in rows]
    index = ShapeIndex(sessions, hub_neighbours=4, exact_max=100)
    index.rebuild()
    kept = index._partitions[KEY].kept
    assert index.keep_neighbourhoods() == len(ids)
    whole_lists = {own: kept.get(own) for own in ids}
    graph = index.neighbour_graph(KEY, 5)
    kept.forget()
    monkeypatch.setattr(_neighbours, "_BLOCK_ROW_PRODUCTS", 300)  # a few rows a block
    computed: list[int] = []
    nearest = _neighbours._nearest
    monkeypatch.setattr(_neighbours, "_nearest",
                        lambda *args: computed.append(1) or nearest(*args))
    assert index.keep_neighbourhoods() == len(ids)
    assert len(computed) > 2 * 19  # more blocks than lists
    for own, entry in whole_lists.items():  # the same, but for float32 rounding
        again = kept.get(own)
        assert entry is not None and again is not None
        assert (again.top, again.kth, again.after) == pytest.approx(
            (entry.top, entry.kth, entry.after), abs=1e-5)
    in_blocks = index.neighbour_graph(KEY, 5)
    assert np.array_equal(in_blocks.neighbours, graph.neighbours)
    assert in_blocks.cosines == pytest.approx(graph.cosines, abs=1e-5)


@pytest.mark.slow
def test_a_change_waits_for_one_block_of_a_lists_rows_not_the_whole_list(
    sessions: sessionmaker[Session], monkeypatch: pytest.MonkeyPatch,
) -> None:
    rows = unit_rows(400, 6, seed=22).astype(np.float32)
    for row in rows[:399]:
        add_ready(sessions, row)
    index = ShapeIndex(sessions, hub_neighbours=4, exact_max=100)
    index.rebuild()
    partition = index._partitions[KEY]
    invlists = faiss.extract_index_ivf(partition.index).invlists
    first_list = next(invlists.list_size(n) for n in range(invlists.nlist)
                      if invlists.list_size(n) > 0)
    monkeypatch.setattr(_neighbours, "_BLOCK_ROW_PRODUCTS", 300)  # a few rows a block
    nearest = _neighbours._nearest
    adding: list[threading.Thread] = []

    def a_model_arrives_meanwhile(*args: object) -> tuple[np.ndarray, np.ndarray]:
        if not adding:  # the first block: the change waits for it, and only for it
            adding.append(threading.Thread(target=index.add, args=(10**6, KEY, rows[399])))
            adding[0].start()
            deadline = time.monotonic() + 5
            while not partition.lock._writers_waiting and time.monotonic() < deadline:
                time.sleep(0.001)  # until the change waits for the lock this block holds
        return nearest(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(_neighbours, "_nearest", a_model_arrives_meanwhile)
    kept = index.keep_neighbourhoods()
    adding[0].join(timeout=5)
    assert not adding[0].is_alive() and 10**6 in index
    assert 0 < kept < first_list  # the first block of the first list, then the change
    assert index.wants_neighbourhoods()


def test_a_candidate_the_index_dropped_comes_after_the_others_in_the_re_rank(
    sessions: sessionmaker[Session],
) -> None:
    from app.search.similarity._shape import reciprocal_keys

    rows = unit_rows(30, 6, seed=14).astype(np.float32)
    ids = [add_ready(sessions, row) for row in rows]
    index = ShapeIndex(sessions, hub_neighbours=4, reciprocal=True)
    index.rebuild()
    query = unit_rows(1, 6, seed=15)[0].astype(np.float32)
    gone = max(ids) + 1000  # found a moment ago, no longer held by the index
    candidates = [*ids[:10], gone]
    hub = np.linspace(0.0, 1.0, len(candidates))
    keys = reciprocal_keys(index, KEY, candidates, hub, query, {})
    assert np.isposinf(keys[-1]) and np.isfinite(keys[:-1]).all()
    # The others are ranked among themselves, as if the dropped one had never been found.
    expected = pool_keys(query, rows[:10], hub[:-1])
    assert keys[:-1] == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize("reciprocal", [False, True], ids=["hub", "reciprocal"])
def test_a_query_model_s_kept_order_answers_as_a_fresh_one_until_the_index_changes(
    sessions: sessionmaker[Session], reciprocal: bool
) -> None:
    from app.search.similarity._orders import ORDERS

    rows = unit_rows(40, 6, seed=11).astype(np.float32)
    vectors = {add_ready(sessions, row): row for row in rows}
    index = ShapeIndex(sessions, hub_neighbours=4, reciprocal=reciprocal)
    index.rebuild()
    ids = list(vectors)

    def answer(query_id: int, k: int) -> list[tuple[int, float, float]]:
        found = search(index, sessions, vectors[query_id], k=k, exclude=query_id,
                       indexed_query=True)
        return [(m.model.index_id, m.distance, m.score) for m in found]

    ORDERS.clear()
    fresh = {(q, k): answer(q, k) for q in ids[:5] for k in (2, 5, 10)}
    assert len(ORDERS) > 0
    computed = {(q, k): answer(q, k) for q in ids[:5] for k in (2, 5, 10)}  # kept orders
    assert computed == fresh
    for q in ids[:5]:
        assert [i for i, _, _ in fresh[q, 10]] == hub_order(
            vectors, vectors[q], 10, 4, exclude=q, reciprocal=reciprocal)
    # A new model near the first query: its kept order is not read again.
    stamp = index.stamp(KEY)
    near = vectors[ids[0]] + 0.01 * rows[1]
    newcomer = add_ready(sessions, (near / np.linalg.norm(near)).astype(np.float32))
    index.sync()
    assert index.stamp(KEY) != stamp
    assert answer(ids[0], 2)[0][0] == newcomer
    vectors[newcomer] = (near / np.linalg.norm(near)).astype(np.float32)
    assert [i for i, _, _ in answer(ids[0], 10)] == hub_order(
        vectors, vectors[ids[0]], 10, 4, exclude=ids[0], reciprocal=reciprocal)
    # A deleted one leaves at once, kept order or not.
    delete_model(sessions, newcomer)
    index.sync()
    assert newcomer not in [i for i, _, _ in answer(ids[0], 10)]
    assert answer(ids[0], 10) == fresh[ids[0], 10]
