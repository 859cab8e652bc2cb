"""The FAISS cache follows the database: rebuilt at start, in step through the change feed,
partitioned by tenant and descriptor version."""

from __future__ import annotations

import uuid
from datetime import timedelta

import numpy as np
import pytest
from sqlalchemy import delete, update
from sqlalchemy.orm import Session, sessionmaker

from app.db.feed import record_event
from app.db.models import IndexEvent, Model, utcnow
from app.db.retention import prune_history
from app.search.index._entry_neighbours import KEPT_MODELS, KeptEntryNeighbours, nearest_models
from app.search.similarity import find_similar, metadata_matches, score_of
from tests.search.conftest import MakeIndex


def unit(seed: int, d: int = 8) -> np.ndarray:
    vector = np.random.default_rng(seed).normal(size=d).astype(np.float32)
    return vector / np.linalg.norm(vector)


def add_ready(
    sessions: sessionmaker[Session],
    vector: np.ndarray,
    *,
    tenant: str = "t",
    version: str = "v1",
    meta: dict[str, object] | None = None,
    views: np.ndarray | None = None,
) -> int:
    """A ready model (with the descriptors of its virtual ``views``, when given), committed
    with its change-feed event, as a worker would."""
    with sessions.begin() as session:
        model = Model(
            id=uuid.uuid4(),
            tenant=tenant,
            meta=meta or {},
            status="ready",
            file_name="x.stl",
            file_size=1,
            file_sha256="0" * 64,
            file_format="stl",
            descriptor=vector.astype(np.float32).tobytes(),
            descriptor_version=version,
            view_descriptors=None if views is None else views.astype(np.float32).tobytes(),
        )
        session.add(model)
        session.flush()
        record_event(session, model.index_id, "ready", tenant)
        return model.index_id


def delete_model(sessions: sessionmaker[Session], index_id: int) -> None:
    with sessions.begin() as session:
        tenant = session.scalar(
            delete(Model).where(Model.index_id == index_id).returning(Model.tenant)
        )
        record_event(session, index_id, "deleted", tenant or "default")


def test_rebuild_loads_every_ready_descriptor(
    sessions: sessionmaker[Session], make_index: MakeIndex
) -> None:
    ids = [add_ready(sessions, unit(i)) for i in range(5)]
    index = make_index(sessions)
    index.rebuild()
    assert len(index) == 5
    nearest = index.search(("t", "v1"), unit(3), 2)
    assert nearest[0][0] == ids[3] and nearest[0][1] == pytest.approx(0, abs=1e-3)


def test_sync_follows_changes_made_elsewhere(
    sessions: sessionmaker[Session], make_index: MakeIndex
) -> None:
    index = make_index(sessions)
    index.rebuild()
    first = add_ready(sessions, unit(1))
    second = add_ready(sessions, unit(2))
    assert len(index) == 0  # not yet seen
    assert index.sync() == 2
    assert first in index and second in index
    delete_model(sessions, first)
    assert index.sync() == 1
    assert first not in index and second in index
    assert index.sync() == 0  # nothing new


def test_an_event_for_a_model_deleted_meanwhile_adds_nothing(
    sessions: sessionmaker[Session], make_index: MakeIndex,
) -> None:
    index = make_index(sessions)
    index.rebuild()
    doomed = add_ready(sessions, unit(1))
    delete_model(sessions, doomed)
    index.sync()
    assert len(index) == 0


def test_an_index_behind_the_pruned_feed_rebuilds_one_following_it_does_not(
    sessions: sessionmaker[Session], make_index: MakeIndex,
) -> None:
    kept = add_ready(sessions, unit(1))
    doomed = add_ready(sessions, unit(2))
    following, behind = make_index(sessions), make_index(sessions)
    following.rebuild()
    behind.rebuild()
    added = add_ready(sessions, unit(3))  # its event is pruned before `behind` reads it
    delete_model(sessions, doomed)  # the tenant's newest event: kept
    assert following.sync() == 2
    with sessions.begin() as session:
        session.execute(update(IndexEvent).values(created_at=utcnow() - timedelta(days=40)))
    assert prune_history(sessions, days=30).index_events == 3
    changes = following.changes

    assert following.sync() == 0 and following.changes == changes  # no rebuild
    behind.sync()  # following the feed alone, it would never add `added`

    for index in (following, behind):
        assert kept in index and added in index and doomed not in index
        assert len(index) == 2


def test_partitions_keep_tenants_and_versions_apart(
    sessions: sessionmaker[Session], make_index: MakeIndex
) -> None:
    mine = add_ready(sessions, unit(1), tenant="a")
    add_ready(sessions, unit(1), tenant="b")
    add_ready(sessions, unit(1), tenant="a", version="v2")
    index = make_index(sessions)
    index.rebuild()
    assert [i for i, _ in index.search(("a", "v1"), unit(1), 10)] == [mine]
    assert index.partition_size(("a", "v2")) == 1
    assert index.search(("nobody", "v1"), unit(1), 10) == []


def test_find_similar_widens_until_k_models_pass_the_filters(
    sessions: sessionmaker[Session], make_index: MakeIndex,
) -> None:
    query = unit(0)
    # 30 near neighbours without the tag, then 3 far ones with it.
    for i in range(30):
        add_ready(sessions, query + 0.01 * unit(100 + i), meta={"tag": "no"})
    tagged = [add_ready(sessions, unit(200 + i), meta={"tag": "yes"}) for i in range(3)]
    index = make_index(sessions)
    index.rebuild()
    with sessions() as session:
        matches = find_similar(
            index, session.connection(), ("t", "v1"), query, k=3, filters={"tag": "yes"}
        )
    assert sorted(m.model.index_id for m in matches) == sorted(tagged)
    assert [m.distance for m in matches] == sorted(m.distance for m in matches)


def test_scores_and_metadata_matching() -> None:
    assert score_of(0.0) == 1.0 and score_of(2.0) == 0.0
    assert score_of(np.sqrt(2)) == pytest.approx(0.5)
    meta = {"material": "steel", "qty": 3, "ok": True}
    assert metadata_matches(meta, {"material": "steel", "qty": "3", "ok": "true"})
    assert not metadata_matches(meta, {"material": "brass"})
    assert not metadata_matches(meta, {"colour": "red"})


def test_nearest_models_keep_each_models_best_cosine_but_not_the_entrys_own() -> None:
    hits = [(3, 0.9), (1, 0.95), (3, 0.97), (7, 0.5), (2, 0.97), (5, 0.8), (6, 0.7), (8, 0.6)]
    models, cosines = nearest_models(hits, own=1)
    assert models.tolist() == [2, 3, 5, 6, 8, 7][:KEPT_MODELS]  # ties in model order
    assert cosines.tolist() == [0.97, 0.97, 0.8, 0.7, 0.6, 0.5][:KEPT_MODELS]
    few_models, few_cosines = nearest_models([(4, 0.3), (1, 0.9)], own=1)
    assert few_models.tolist() == [4] + [-1] * (KEPT_MODELS - 1)
    assert few_cosines[0] == 0.3 and not few_cosines[1:].any()


def test_kept_entry_neighbours_forget_an_older_stamp_and_stay_bounded() -> None:
    kept = KeptEntryNeighbours(capacity=5)
    neighbours = nearest_models([(2, 0.5)], own=1)
    kept.put("a", (1, 1), {10: neighbours, 11: neighbours})
    kept.put("b", (1, 1), {20: neighbours})
    assert kept.get("a", (1, 1), [10, 12])[0] is neighbours
    assert kept.get("a", (1, 1), [10, 12])[1] is None
    assert kept.get("a", (1, 2), [10]) == [None]  # the partition changed since
    kept.put("a", (1, 2), {12: neighbours})
    assert kept.get("a", (1, 1), [10]) == [None] and len(kept) == 2
    kept.put("b", (1, 1), {21: neighbours, 22: neighbours, 23: neighbours})
    assert len(kept) <= 5
    assert kept.get("b", (1, 1), [23])[0] is neighbours
    kept.put("c", 0, {i: neighbours for i in range(6)})  # more than it may hold: not kept
    assert len(kept) <= 5 and kept.get("c", 0, [0]) == [None]
