"""The store of hub-discount neighbourhoods a partition keeps (``app.search.index._kept``):
what a pass keeps, what it carries over, what a forget drops, and its memory per model."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from app.search.index._kept import KeptNeighbourhoods, Neighbourhood

K = 3


def largest_cosines(count: int, seed: int) -> np.ndarray:
    """``(count, K + 1)`` float32 cosines, each row falling."""
    rows = np.random.default_rng(seed).uniform(-1, 1, size=(count, K + 1))
    return -np.sort(-rows, axis=1).astype(np.float32)


def members_of(ids: np.ndarray) -> np.ndarray:
    """``(m, K + 1)`` made-up neighbour ids of each of ``ids``."""
    return np.asarray(ids, dtype=np.int64)[:, None] + 1000 + np.arange(K + 1)


def test_a_pass_keeps_what_each_row_of_cosines_says() -> None:
    kept = KeptNeighbourhoods()
    kept.use(K)
    ids = np.array([40, 7, 12, 99, 3], dtype=np.int64)
    kept.start_pass(ids)
    cosines = largest_cosines(5, seed=1)
    # A pass fills its table block by block.
    kept.put_block(ids[:3], cosines[:3], members_of(ids[:3]))
    found = kept.lookup([7, 3, 40, 12, 99, 1000])
    for own, row, entry in zip([7, 40, 12], cosines[[1, 0, 2]], [found[0], found[2], found[3]],
                               strict=True):
        assert entry is not None, own
        assert (entry.top, entry.kth, entry.after) == pytest.approx(
            (float(row[:K].astype(np.float64).sum()), float(row[K - 1]), float(row[K])))
    assert found[1] is None and found[4] is None and found[5] is None  # not computed yet
    assert len(kept) == 3


def test_a_query_s_own_entry_and_a_new_pass_carry_on() -> None:
    kept = KeptNeighbourhoods()
    kept.use(K)
    kept.start_pass(np.array([1, 2, 3], dtype=np.int64))
    three = np.array([1, 2, 3], dtype=np.int64)
    kept.put_block(three, largest_cosines(3, seed=2), members_of(three))
    first = kept.lookup([1, 2, 3])
    kept.put(50, Neighbourhood(1.5, 0.4, 0.3))  # a model added later, kept by a query
    # A second pass over a changed partition (2 removed, 60 added) keeps what the first
    # held of models still there until it computes them again.
    kept.start_pass(np.array([60, 3, 1, 50], dtype=np.int64))
    assert kept.lookup([1, 3, 2, 50, 60]) == [first[0], first[2], None,
                                              Neighbourhood(1.5, 0.4, 0.3), None]
    kept.forget()
    assert kept.lookup([1, 3, 50]) == [None, None, None] and len(kept) == 0


def test_another_k_forgets_everything() -> None:
    kept = KeptNeighbourhoods()
    kept.use(K)
    kept.start_pass(np.array([1, 2], dtype=np.int64))
    two = np.array([1, 2], dtype=np.int64)
    kept.put_block(two, largest_cosines(2, seed=3), members_of(two))
    kept.use(K + 1)
    assert kept.get(1) is None and len(kept) == 0


def test_a_pass_costs_a_few_dozen_bytes_per_model() -> None:
    # No Python object per model: at 10^6 models a dict of objects would hold ~230 MB per
    # API process; the table holds an id, three floats, a flag and the low 32 bits of the
    # K + 1 members' ids (33 + 4 (K + 1) bytes: 49 here, 77 at the service's k of 10).
    count = 20_000
    ids = np.random.default_rng(4).permutation(10 * count)[:count].astype(np.int64)
    cosines = largest_cosines(count, seed=5)
    kept = KeptNeighbourhoods()
    kept.use(K)
    tracemalloc.start()
    try:
        kept.start_pass(ids)
        for start in range(0, count, 1000):
            block = ids[start:start + 1000]
            kept.put_block(block, cosines[start:start + 1000], members_of(block))
        held, _ = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(kept) == count
    assert held / count < 33 + 4 * (K + 1) + 8
    entry = kept.get(int(ids[123]))
    assert entry is not None and entry.kth == pytest.approx(float(cosines[123, K - 1]))
