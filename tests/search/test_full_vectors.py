"""The full vectors of a compressed partition (app.search.full_vectors): exact rows by id in a
memory-mapped file whose freed rows are reused, and the index re-ranking from them."""

from __future__ import annotations

import errno
import os

import numpy as np
import pytest
from sqlalchemy import update
from sqlalchemy.orm import Session, sessionmaker

from app.db.models import Model
from app.search import full_vectors
from app.search.full_vectors import FullVectors
from app.search.index import ShapeIndex
from app.search.similarity import find_similar
from tests.search.test_index import add_ready, unit

D = 40
KEY = ("t", "v1")


def test_rows_come_back_exactly_by_id_and_unknown_ids_are_masked() -> None:
    rng = np.random.default_rng(0)
    store = FullVectors(7)
    vectors = rng.normal(size=(3000, 7)).astype(np.float32)  # past the first file size
    store.put(list(range(100, 3100)), vectors)
    got, held = store.get([100, 3099, 5, 2000])
    assert held.tolist() == [True, True, False, True]
    assert np.array_equal(got[[0, 1, 3]], vectors[[0, 2999, 1900]])
    assert not got[2].any()
    store.put([100], vectors[5:6])  # overwriting an id keeps its row
    assert np.array_equal(store.get([100])[0][0], vectors[5]) and len(store) == 3000


def test_freed_rows_are_reused_so_churn_does_not_grow_the_file() -> None:
    store = FullVectors(16)
    store.put(list(range(2000)), np.ones((2000, 16)))
    size = store.file_bytes
    for round_ in range(5):  # replace every model by a new id, five times over
        old = range(round_ * 2000, (round_ + 1) * 2000)
        store.drop(list(old))
        store.put([i + 2000 for i in old], np.full((2000, 16), round_))
    assert store.file_bytes == size and len(store) == 2000
    assert 3000 not in store and 11999 in store
    assert store.get([11999])[0][0].tolist() == [4.0] * 16


@pytest.mark.slow
def test_a_compressed_partition_re_ranks_from_its_full_vectors_not_the_database(
    sessions: sessionmaker[Session],
) -> None:
    """The distances of a compressed partition are exact against the vectors the index was
    given, whatever the database's descriptor column says now: no descriptor is read back
    per query, and the vectors survive growth past the exact limit and removals."""
    rng = np.random.default_rng(2)
    vectors = {}
    for i in range(120):
        vector = unit(i % 4, D) + 0.3 * rng.normal(size=D).astype(np.float32)
        vectors[add_ready(sessions, vector / np.linalg.norm(vector))] = vector / np.linalg.norm(
            vector
        )
    # Plain order (no hub discount): exact distances are what is tested; every list: exact recall.
    index = ShapeIndex(sessions, exact_max=50, nprobe=64, hub_neighbours=0)
    index.rebuild()
    assert index.describe(KEY) == "ivf-sq8"
    ids = list(vectors)
    late = add_ready(sessions, unit(1, D))  # added by a sync to the compressed partition
    vectors[late] = unit(1, D)
    index.sync()
    index.remove_many(ids[:10])
    for index_id in (ids[10], ids[-1], late):
        assert np.array_equal(index.vector(KEY, index_id), vectors[index_id].astype(np.float32))
    assert index.vector(KEY, ids[0]) is None
    with sessions.begin() as session:  # a descriptor column the query must not consult
        session.execute(update(Model).values(descriptor=np.zeros(D, np.float32).tobytes()))
    query = unit(1, D)
    with sessions() as session:
        matches = find_similar(index, session.connection(), KEY, query, k=5)
    held = {i: v for i, v in vectors.items() if i not in ids[:10]}
    expected = sorted(held, key=lambda i: (float(np.linalg.norm(held[i] - query)), i))[:5]
    assert [m.model.index_id for m in matches] == expected
    for m in matches:  # exact, not the codes' estimates (errors of ~1e-3 here)
        assert abs(m.distance - float(np.linalg.norm(held[m.model.index_id] - query))) < 1e-6


def _no_space(*_args: object) -> None:
    raise OSError(errno.ENOSPC, "No space left on device")


def test_a_full_disk_is_an_error_that_changes_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    store = FullVectors(4)
    store.put(list(range(1024)), np.ones((1024, 4)))  # the first size, full
    monkeypatch.setattr(os, "posix_fallocate", _no_space)
    with pytest.raises(OSError, match="No space"):
        store.put([5000, 7], np.full((2, 4), 2.0))  # one new id: the file must grow
    assert len(store) == 1024 and 5000 not in store
    assert store.get([7])[0][0].tolist() == [1.0] * 4  # the held id not overwritten either
    store.put([7], np.full((1, 4), 3.0))  # a held id needs no room
    assert store.get([7])[0][0].tolist() == [3.0] * 4


@pytest.mark.slow
def test_a_sync_that_finds_the_disk_full_adds_nothing_and_a_later_one_catches_up(
    sessions: sessionmaker[Session], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(full_vectors, "_MIN_ROWS", 1)  # the file fits the build exactly
    ids = [add_ready(sessions, unit(i % 4, D)) for i in range(60)]
    index = ShapeIndex(sessions, exact_max=50, nprobe=64)
    index.rebuild()
    assert index.describe(KEY) == "ivf-sq8"
    late = add_ready(sessions, unit(1, D))
    with monkeypatch.context() as full_disk:
        full_disk.setattr(os, "posix_fallocate", _no_space)
        with pytest.raises(OSError, match="No space"):
            index.sync()
        assert late not in index
        assert late not in [i for i, _ in index.search(KEY, unit(1, D), 100)]
        assert np.array_equal(index.vector(KEY, ids[1]), unit(1, D))  # the rest still held
    index.sync()  # room again: the event is applied now
    assert late in index and np.array_equal(index.vector(KEY, late), unit(1, D))
