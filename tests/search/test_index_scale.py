"""The index at scale, in miniature: compressed (IVF-SQ8, IVF-SQ4) partitions re-ranked exactly,
batched removals, growth past the exact limit, and metadata filters pushed down to SQL."""

from __future__ import annotations

import uuid

import numpy as np
import pytest
from sqlalchemy import select, update
from sqlalchemy.orm import Session, sessionmaker

from app.db.models import Model
from app.search.index import ShapeIndex
from app.search.similarity import QueryChanged, find_similar, matching_ids
from tests.search.test_index import add_ready, delete_model, unit

D = 40
KEY = ("t", "v1")


def exact_order(vectors: dict[int, np.ndarray], query: np.ndarray) -> list[int]:
    """Ids by exact L2 distance to ``query``, ties by id (the service's order)."""
    return sorted(vectors, key=lambda i: (float(np.linalg.norm(vectors[i] - query)), i))


@pytest.mark.slow
@pytest.mark.parametrize(("compact_min", "kind"), [(10**6, "ivf-sq8"), (200, "ivf-sq4")])
def test_a_compressed_partition_answers_exactly_after_re_ranking(
    sessions: sessionmaker[Session], compact_min: int, kind: str
) -> None:
    rng = np.random.default_rng(0)
    centres = [unit(1000 + c, D) for c in range(6)]
    vectors = {}
    for i in range(300):
        vector = centres[i % 6] + 0.15 * rng.normal(size=D).astype(np.float32) / np.sqrt(D)
        vector /= np.linalg.norm(vector)
        vectors[add_ready(sessions, vector)] = vector
    # Plain distance order (no hub discount): the exact re-rank is what is tested.
    index = ShapeIndex(sessions, exact_max=100, compact_min=compact_min, nprobe=4,
                       hub_neighbours=0)
    index.rebuild()
    assert index.describe(KEY) == kind and len(index) == 300
    assert index.nbytes() < 300 * 4 * D  # under half of what float32 rows would hold
    with sessions() as session:
        for q in range(5):
            query = vectors[list(vectors)[q * 37]]
            matches = find_similar(index, session.connection(), KEY, query, k=10)
            assert [m.model.index_id for m in matches] == exact_order(vectors, query)[:10]
            # Distances are exact (from the stored vectors), not quantised estimates.
            for m in matches:
                exact = float(np.linalg.norm(vectors[m.model.index_id] - query))
                assert m.distance == pytest.approx(exact, abs=1e-5)


def built_by_kind(sessions: sessionmaker[Session]) -> dict[str, ShapeIndex]:
    """300 ready vectors, rebuilt as each kind of partition: flat, 8-bit and 4-bit codes."""
    for i in range(300):
        add_ready(sessions, unit(i, D))
    indexes = {}
    for exact_max, compact_min in ((10**6, 10**6), (100, 10**6), (100, 200)):
        index = ShapeIndex(sessions, exact_max=exact_max, compact_min=compact_min, nprobe=4)
        index.rebuild()
        indexes[index.describe(KEY)] = index
    return indexes


@pytest.mark.slow
def test_four_bit_codes_take_half_of_the_eight_bit_ones(
    sessions: sessionmaker[Session],
) -> None:
    sizes = {kind: index.nbytes() for kind, index in built_by_kind(sessions).items()}
    # Same lists and ids; each of the 300 codes of 48 padded dims shrinks from 48 to 24 bytes.
    assert sizes["ivf-sq8"] - sizes["ivf-sq4"] == 300 * (48 - 24)


def sparse_unit(seed: int, varying: int = 16) -> np.ndarray:
    """A unit vector of ``D`` dimensions whose last ``D - varying`` are zero, as real
    descriptors' histogram bins that no shape reaches."""
    vector = np.zeros(D, dtype=np.float32)
    vector[:varying] = unit(seed, varying)
    return vector


@pytest.mark.slow
def test_codes_leave_out_the_dimensions_constant_over_the_training_sample(
    sessions: sessionmaker[Session], monkeypatch: pytest.MonkeyPatch
) -> None:
    vectors = {add_ready(sessions, sparse_unit(i)): sparse_unit(i) for i in range(300)}
    index = ShapeIndex(sessions, exact_max=100, nprobe=4)
    index.rebuild()
    # The same vectors with every dimension coded: what the index did before.
    monkeypatch.setattr("app.search.index._partition._varying_dimensions", lambda _: None)
    every = ShapeIndex(sessions, exact_max=100, nprobe=4)
    every.rebuild()
    assert index.describe(KEY) == every.describe(KEY) == "ivf-sq8"
    # 16 coded dimensions instead of 48 padded ones: 32 bytes less per code, and centroids.
    assert index.nbytes() <= every.nbytes() - 300 * 32
    # A constant dimension adds the same to every estimate: the same candidates, the same
    # estimated distances.
    for q in range(5):
        query = sparse_unit(1000 + q)
        short, full = index.search(KEY, query, 30), every.search(KEY, query, 30)
        assert [i for i, _ in short] == [i for i, _ in full]
        np.testing.assert_allclose([d for _, d in short], [d for _, d in full], atol=1e-5)
    # A model added later with weight in a left-out dimension: the codes do not see it, the
    # exact re-rank does.
    query = vectors[list(vectors)[7]]
    odd = query.copy()
    odd[D - 1] = 0.05
    odd /= np.linalg.norm(odd)
    late = add_ready(sessions, odd)
    index.sync()
    with sessions() as session:
        matches = find_similar(index, session.connection(), KEY, query, k=3)
    assert [m.model.index_id for m in matches][:2] == [list(vectors)[7], late]
    assert matches[1].distance == pytest.approx(float(np.linalg.norm(odd - query)), abs=1e-5)


@pytest.mark.slow
def test_coarser_codes_fetch_a_wider_margin_for_the_exact_re_rank(
    sessions: sessionmaker[Session],
) -> None:
    indexes = built_by_kind(sessions)
    fetched = {kind: index.rerank_candidates(KEY, 10) for kind, index in indexes.items()}
    # Exact: what is asked; 8-bit: max(2k, k + 10); 4-bit estimates err more: twice that.
    assert fetched == {"flat": 10, "ivf-sq8": 20, "ivf-sq4": 40}
    assert indexes["ivf-sq4"].rerank_candidates(("t", "no such version"), 10) == 10


def test_removals_are_batched_and_growth_past_the_limit_compresses(
    sessions: sessionmaker[Session],
) -> None:
    index = ShapeIndex(sessions, exact_max=50, nprobe=64)
    index.rebuild()
    ids = [add_ready(sessions, unit(i, D)) for i in range(40)]
    index.sync()
    assert index.describe(KEY) == "flat"
    ids += [add_ready(sessions, unit(i, D)) for i in range(40, 120)]
    index.sync()
    assert index.describe(KEY) == "ivf-sq8" and index.partition_size(KEY) == 120
    index.remove_many(ids[:60] + [10**9])  # an unknown id is ignored
    assert index.partition_size(KEY) == 60 and ids[0] not in index and ids[60] in index
    for doomed in ids[60:70]:
        delete_model(sessions, doomed)
    index.sync()
    assert index.partition_size(KEY) == 50
    hits = index.search(KEY, unit(100, D), 5)
    assert hits[0][0] == ids[100]
    assert not set(ids[:70]) & {i for i, _ in index.search(KEY, unit(100, D), 50)}


def test_search_batch_answers_each_query_like_search(sessions: sessionmaker[Session]) -> None:
    for i in range(30):
        add_ready(sessions, unit(i, D))
    index = ShapeIndex(sessions)
    index.rebuild()
    queries = np.stack([unit(i, D) for i in (3, 17)])
    batch = index.search_batch(KEY, queries, 4)
    assert batch == [index.search(KEY, q, 4) for q in queries]


@pytest.mark.parametrize("exact_max", [10_000, 20])
def test_a_selective_filter_is_pushed_down_and_still_returns_k(
    sessions: sessionmaker[Session], exact_max: int
) -> None:
    query = unit(0, D)
    # 60 near neighbours of other families, then 4 far models of the rare family, one of
    # them with a number as its value.
    for i in range(60):
        near = query + 0.01 * unit(100 + i, D)
        add_ready(sessions, near / np.linalg.norm(near), meta={"family": "common", "qty": 3})
    rare = [add_ready(sessions, unit(200 + i, D), meta={"family": "rare"}) for i in range(3)]
    numeric = add_ready(sessions, unit(300, D), meta={"family": 7})
    index = ShapeIndex(sessions, exact_max=exact_max)
    index.rebuild()
    with sessions() as session:
        assert (
            sorted(matching_ids(session.connection(), KEY, {"family": "rare"}, limit=10) or [])
            == rare
        )
        assert (
            matching_ids(session.connection(), KEY, {"family": "common"}, limit=10) is None
        )  # broad
        # The limit is inclusive: as many as it, pushed down; one more, not.
        at_limit = matching_ids(session.connection(), KEY, {"family": "rare"}, limit=len(rare))
        assert sorted(at_limit or []) == rare
        assert matching_ids(session.connection(), KEY, {"family": "rare"},
                            limit=len(rare) - 1) is None
        assert matching_ids(session.connection(), KEY, {"family": "7"}, limit=10) == [numeric]
        assert (
            matching_ids(session.connection(), KEY, {"qty": "3", "family": "rare"}, limit=10) == []
        )
        pushed = find_similar(
            index, session.connection(), KEY, query, k=3, filters={"family": "rare"}
        )
        widened = find_similar(
            index, session.connection(), KEY, query, k=3, filters={"family": "rare"}, pushdown_max=0
        )
        assert [m.model.index_id for m in pushed] == [m.model.index_id for m in widened]
        assert sorted(m.model.index_id for m in pushed) == rare
        # Fewer matching models than k: all of them, nothing else.
        seven = find_similar(index, session.connection(), KEY, query, k=5, filters={"family": "7"})
        assert [m.model.index_id for m in seven] == [numeric]


def public_id(sessions: sessionmaker[Session], index_id: int) -> uuid.UUID:
    with sessions() as session:
        return session.scalars(select(Model.id).where(Model.index_id == index_id)).one()


@pytest.mark.slow
@pytest.mark.parametrize("exact_max", [10**6, 100], ids=["flat", "ivf-sq8"])
def test_a_query_by_model_id_from_the_index_answers_as_the_database_would(
    sessions: sessionmaker[Session], exact_max: int
) -> None:
    """The query vector from the index (exact in IVF too) and the query's row confirmed
    with the candidates': the same results and exact distances as with the stored vector."""
    rng = np.random.default_rng(1)
    vectors = {}
    for i in range(300):
        vector = unit(2000 + i % 5, D) + 0.2 * rng.normal(size=D).astype(np.float32) / np.sqrt(D)
        vector /= np.linalg.norm(vector)
        vectors[add_ready(sessions, vector)] = vector
    index = ShapeIndex(sessions, exact_max=exact_max, nprobe=16)
    index.rebuild()
    with sessions() as session:
        for query_id in list(vectors)[::60]:
            located = index.locate("t", public_id(sessions, query_id))
            assert located == (query_id, KEY)
            copy = index.vector(KEY, query_id)
            assert copy is not None and copy.shape == (D,)
            # Exactly the stored float32 vector, in a compressed partition too (its full
            # vectors, not the codes decoded).
            assert np.array_equal(copy, vectors[query_id].astype(np.float32))
            answer = find_similar(
                index, session.connection(), KEY, copy, k=10, exclude=query_id, indexed_query=True
            )
            stored = find_similar(
                index, session.connection(), KEY, vectors[query_id], k=10, exclude=query_id
            )
            assert [m.model.index_id for m in answer] == [m.model.index_id for m in stored]
            assert [m.distance for m in answer] == pytest.approx([m.distance for m in stored])
    assert index.locate("other-tenant", public_id(sessions, query_id)) is None


@pytest.mark.parametrize("pushdown_max", [10_000, 0], ids=["sql-ids", "rows-screened"])
def test_a_query_model_gone_from_the_database_is_not_answered_from_the_index(
    sessions: sessionmaker[Session], pushdown_max: int,
) -> None:
    # A filter every model passes: with pushdown_max 0 SQL hands over no ids, and the hub
    # answer reads the candidates' rows before ordering them, the query's row apart.
    ids = [add_ready(sessions, unit(i, D), meta={"kind": "part"}) for i in range(20)]
    index = ShapeIndex(sessions)
    index.rebuild()
    gone, changed = ids[0], ids[1]
    model_ids = {i: public_id(sessions, i) for i in (gone, changed)}
    delete_model(sessions, gone)  # the index has not synced: it still holds both
    with sessions.begin() as session:
        session.execute(update(Model).where(Model.index_id == changed).values(status="processing"))
    for index_id in (gone, changed):
        assert index.locate("t", model_ids[index_id]) == (index_id, KEY)
        with sessions() as session, pytest.raises(QueryChanged):
            find_similar(
                index,
                session.connection(),
                KEY,
                index.vector(KEY, index_id),
                k=5,
                exclude=index_id,
                indexed_query=True,
                filters={"kind": "part"},
                pushdown_max=pushdown_max,
            )
    index.sync()
    assert index.locate("t", model_ids[gone]) is None
    assert index.vector(KEY, gone) is None


@pytest.mark.slow
@pytest.mark.parametrize("hub_neighbours", [0, 10], ids=["plain", "hub"])
def test_models_gone_from_the_database_are_replaced_by_the_next_nearest(
    sessions: sessionmaker[Session], hub_neighbours: int
) -> None:
    # A compressed partition confirms its candidates nearest first by exact distance, as
    # many as the answer takes: models the index still holds but the database no longer
    # has (deleted a moment ago, not yet synced) are made up for by the next ones.
    rng = np.random.default_rng(4)
    vectors = {}
    for _ in range(200):
        vector = rng.normal(size=D).astype(np.float32)
        vector /= np.linalg.norm(vector)
        vectors[add_ready(sessions, vector)] = vector
    index = ShapeIndex(sessions, exact_max=50, nprobe=64, hub_neighbours=hub_neighbours)
    index.rebuild()
    assert index.is_approximate(KEY)
    query = vectors[list(vectors)[7]]
    with sessions() as session:
        before = find_similar(index, session.connection(), KEY, query, k=10)
    gone = [m.model.index_id for m in before[:6]]
    with sessions.begin() as session:  # behind the index's back: no change-feed event
        session.execute(update(Model).where(Model.index_id.in_(gone)).values(status="failed"))
    with sessions() as session:
        after = find_similar(index, session.connection(), KEY, query, k=10)
    remaining = {i: v for i, v in vectors.items() if i not in gone}
    assert len(after) == 10 and not set(gone) & {m.model.index_id for m in after}
    if hub_neighbours == 0:
        assert [m.model.index_id for m in after] == exact_order(remaining, query)[:10]
