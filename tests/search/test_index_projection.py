"""Projected IVF codes: a wide descriptor's codes hold its leading principal components,
and the exact re-rank against the full vectors gives back the true neighbours."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from app.search.index import ShapeIndex
from app.search.index._projection import Projection

D = 600  # padded to 608: at least twice the projected dimensions plus oversampling
KEY = ("t", "wide")
PROJECTED_DIMS = 256


def structured(count: int, seed: int) -> np.ndarray:
    """``(count, D)`` unit vectors near a 40-dimensional subspace, as descriptors of real
    parts are (bench/index_projection.py), with a little noise off it."""
    rng = np.random.default_rng(seed)
    basis = np.linalg.qr(np.random.default_rng(99).normal(size=(D, 40)))[0].T
    vectors = rng.normal(size=(count, 40)) @ basis + 0.02 * rng.normal(size=(count, D))
    return (vectors / np.linalg.norm(vectors, axis=1, keepdims=True)).astype(np.float32)


def test_the_projection_is_orthonormal_deterministic_and_never_overstates_a_distance() -> None:
    sample = structured(800, 1)
    projection = Projection.fit(sample, 64)
    again = Projection.fit(sample, 64)
    assert np.array_equal(projection.components_, again.components_)
    gram = projection.components_ @ projection.components_.T
    np.testing.assert_allclose(gram, np.eye(64), atol=1e-5)
    # Orthonormal rows: a pair's projected distance is at most its distance.
    a, b = structured(200, 2), structured(200, 3)
    projected = np.linalg.norm(projection.apply(a) - projection.apply(b), axis=1)
    assert (projected <= np.linalg.norm(a - b, axis=1) + 1e-5).all()
    # The planted 40-dimensional structure is found: new vectors keep nearly all their
    # spread; random directions of the same count would keep about 64 / 600 of it.
    fresh = structured(300, 4)
    kept = projection.apply(fresh).var(axis=0).sum() / fresh.var(axis=0).sum()
    assert kept > 0.9


def test_a_projection_needs_more_rows_than_directions() -> None:
    with pytest.raises(ValueError, match="directions need more"):
        Projection.fit(structured(100, 5), 64)


def chunks(vectors: np.ndarray, size: int = 500) -> Iterator[tuple[int, np.ndarray]]:
    for start in range(0, len(vectors), size):
        yield start, vectors[start : start + size]


def top(index: ShapeIndex, query: np.ndarray, k: int) -> list[int]:
    """The service's answer: candidates from the codes, re-ranked exactly."""
    hits = [i for i, _ in index.search(KEY, query, index.rerank_candidates(KEY, k))]
    vectors, held = index.exact_vectors(KEY, hits)
    assert held.all()
    distances = np.linalg.norm(vectors - query, axis=1)
    return [hits[i] for i in np.argsort(distances, kind="stable")[:k]]


def test_a_wide_partition_holds_principal_components_and_answers_exactly() -> None:
    vectors = structured(2000, 6)
    # Every one of the 44 lists probed: what is left to miss a neighbour is the projection.
    index = ShapeIndex(None, exact_max=100, nprobe=64, projected_dims=PROJECTED_DIMS)
    index.build_partition(KEY, chunks(vectors), expected=len(vectors))
    assert index.describe(KEY) == f"pca{PROJECTED_DIMS}-ivf-sq8"
    # A code (and each of the sqrt(2000) = 44 centroids) holds 256 values instead of 608,
    # at the price of the projection itself: a (256, 608) matrix and a mean.
    whole = ShapeIndex(None, exact_max=100, nprobe=64)
    whole.build_partition(KEY, chunks(vectors), expected=len(vectors))
    saved = (len(vectors) + 4 * 44) * (608 - PROJECTED_DIMS) - 4 * (608 + PROJECTED_DIMS * 608)
    assert whole.nbytes() - index.nbytes() == saved
    # The full vectors stay exact.
    held, found = index.exact_vectors(KEY, [0, 1999])
    assert found.all() and np.array_equal(held, vectors[[0, 1999]])
    queries = structured(20, 7)
    for query in queries:
        exact = np.argsort(np.linalg.norm(vectors - query, axis=1), kind="stable")[:10]
        assert top(index, query, 10) == exact.tolist()


def test_vectors_added_after_the_projection_was_fitted_are_found() -> None:
    vectors = structured(1500, 8)
    index = ShapeIndex(None, exact_max=100, nprobe=8, projected_dims=PROJECTED_DIMS)
    index.build_partition(KEY, chunks(vectors), expected=len(vectors))
    later = structured(5, 9)
    for i, vector in enumerate(later):
        index.add(5000 + i, KEY, vector)
    for i, vector in enumerate(later):
        assert top(index, vector, 1) == [5000 + i]
    index.remove_many([5000])
    assert 5000 not in top(index, later[0], 10)


def test_narrow_descriptors_and_the_default_keep_every_dimension_in_their_codes() -> None:
    narrow = structured(2000, 10)[:, :200]
    narrow /= np.linalg.norm(narrow, axis=1, keepdims=True)
    index = ShapeIndex(None, exact_max=100, nprobe=8, projected_dims=PROJECTED_DIMS)
    index.build_partition(KEY, chunks(narrow), expected=len(narrow))
    assert index.describe(KEY) == "ivf-sq8"
    default = ShapeIndex(None, exact_max=100, nprobe=8)  # SHAPESEARCH_INDEX_PROJECTED_DIMS 0
    default.build_partition(KEY, chunks(structured(2000, 6)), expected=2000)
    assert default.describe(KEY) == "ivf-sq8"


def test_the_duplicates_graph_of_a_projected_partition_compares_the_full_vectors() -> None:
    vectors = structured(1200, 11)
    projected = ShapeIndex(None, exact_max=100, nprobe=64, projected_dims=PROJECTED_DIMS)
    projected.build_partition(KEY, chunks(vectors), expected=len(vectors))
    flat = ShapeIndex(None, exact_max=10**6)
    flat.build_partition(KEY, chunks(vectors), expected=len(vectors))
    graph, reference = projected.neighbour_graph(KEY, 5), flat.neighbour_graph(KEY, 5)
    assert projected.describe(KEY).startswith("pca") and graph.exact
    # Same neighbours and the same exact cosines, row for row of each id.
    order, reference_order = np.argsort(graph.ids), np.argsort(reference.ids)
    by_id = graph.ids[graph.neighbours[order]]
    assert np.array_equal(by_id, reference.ids[reference.neighbours[reference_order]])
    np.testing.assert_allclose(
        graph.cosines[order], reference.cosines[reference_order], atol=1e-6
    )


def test_a_flat_partition_that_outgrows_its_limit_is_compressed_with_a_projection() -> None:
    vectors = structured(800, 12)
    index = ShapeIndex(None, exact_max=600, nprobe=64, projected_dims=PROJECTED_DIMS)
    for index_id, vector in enumerate(vectors[:600]):
        index.add(index_id, KEY, vector)
    assert index.describe(KEY) == "flat"
    for index_id, vector in enumerate(vectors[600:], start=600):  # past the limit
        index.add(index_id, KEY, vector)
    assert index.describe(KEY) == f"pca{PROJECTED_DIMS}-ivf-sq8"
    assert index.partition_size(KEY) == 800
    for query in structured(10, 13):
        exact = np.argsort(np.linalg.norm(vectors - query, axis=1), kind="stable")[:10]
        assert top(index, query, 10) == exact.tolist()


def test_the_index_counts_its_partitions_by_kind() -> None:
    index = ShapeIndex(None, exact_max=100, nprobe=8, projected_dims=PROJECTED_DIMS)
    index.build_partition(KEY, chunks(structured(1000, 14)), expected=1000)
    index.build_partition(("t", "narrow"), chunks(structured(50, 15)), expected=50)
    index.build_partition(("u", "wide"), chunks(structured(1000, 16)), expected=1000)
    assert index.kinds() == {f"pca{PROJECTED_DIMS}-ivf-sq8": 2, "flat": 1}
