"""k-reciprocal re-ranking (``core.rank.reciprocal``): the vectorised keys against a count by the
paper's set definitions, the service's pool against the whole catalogue, what reciprocity
changes in an order, the hub discount's first answer kept, the query's own part first, and
rotation invariance."""

from __future__ import annotations

import numpy as np
import pytest

from core.rank.hubness import (
    SAME_DESCRIPTOR,
    hub_discounted_keys,
    hub_keys,
    neighbourhood_radii,
    rerank_depth,
)
from core.rank.reciprocal import (
    RECIPROCAL_POOL,
    _weights,
    first_kept,
    pool_keys,
    reciprocal_depth,
    reciprocal_keys,
    rescaled_rows,
)
from tests.core.test_hubness import unit_rows


def set_count_weights(scaled: np.ndarray, order: list[list[int]], k1: int, k2: int
                      ) -> np.ndarray:
    """Zhong et al.'s ``V`` with Python sets, one model at a time: the neighbourhoods in
    ``order`` (each row's models, nearest first), the weights ``exp(-scaled)``."""
    m = len(scaled)

    def nearest(i: int, k: int) -> set[int]:
        return set(order[i][: k + 1])

    def reciprocal(i: int, k: int) -> set[int]:
        return {j for j in nearest(i, k) if i in nearest(j, k)}

    weights = np.zeros((m, m))
    for i in range(m):
        core = reciprocal(i, k1)
        expanded = set(core)
        for j in core:
            candidate = reciprocal(j, max(1, round(k1 / 2)))
            if len(candidate & core) > 2 / 3 * len(candidate):
                expanded |= candidate
        for j in expanded:
            weights[i, j] = np.exp(-scaled[i, j])
        weights[i] /= weights[i].sum()
    return np.array([weights[order[i][:k2]].mean(axis=0) for i in range(m)])


def set_count_keys(rows: np.ndarray, k1: int, k2: int, blend: float,
                   term: np.ndarray | None) -> np.ndarray:
    """Zhong et al.'s definitions with Python sets, one pair at a time."""
    m = len(rows)
    squared = np.maximum(2.0 - 2.0 * rows @ rows.T, 0.0)
    scaled = squared / squared.max(axis=1, keepdims=True)
    order = [sorted(range(m), key=lambda j, i=i: (scaled[i, j], j)) for i in range(m)]
    weights = set_count_weights(scaled, order, k1, k2)
    jaccard = np.array([[1 - np.minimum(weights[i], weights[j]).sum()
                         / np.maximum(weights[i], weights[j]).sum() for j in range(m)]
                        for i in range(m)])
    keys = (1 - blend) * jaccard + blend * (scaled if term is None else term)
    keys = np.where(np.sqrt(squared) <= SAME_DESCRIPTOR, -np.inf, keys)
    if term is not None:  # the term's first answer among the others goes first
        for i in range(m):
            others = [j for j in range(m) if np.isfinite(keys[i, j])]
            first = min(others, key=lambda j, i=i: (term[i, j], j))
            keys[i, first] = min(keys[i, j] for j in others) - 1
    return keys


@pytest.mark.parametrize(("k1", "k2"), [(5, 3), (5, 1), (3, 2), (8, 3)])
@pytest.mark.parametrize("hub_term", [False, True], ids=["paper", "hub-term"])
def test_the_keys_are_the_set_definitions(k1: int, k2: int, hub_term: bool) -> None:
    rows = unit_rows(40, 6, seed=11)
    rows[7] = rows[3]  # one part uploaded twice
    term = rescaled_rows(hub_discounted_keys(rows, rows, 10, 1.0,
                                             exclude=np.eye(40, dtype=bool))) if hub_term else None
    expected = set_count_keys(rows, k1, k2, 0.3, term)
    keys = reciprocal_keys(rows, term, k1, k2, 0.3)
    assert np.array_equal(np.isinf(keys), np.isinf(expected))
    assert np.isinf(keys[3, 7]) and np.isinf(keys[7, 3])
    finite = np.isfinite(expected)
    assert keys[finite] == pytest.approx(expected[finite], abs=1e-12)


def test_neighbourhoods_taken_in_another_order_are_the_set_definitions_in_it() -> None:
    # The hub-neighbourhoods study (see the changelog) ranked neighbourhoods by the hub discount's
    # keys and keeps the weights of plain distance.
    rows = unit_rows(40, 6, seed=5)
    squared = np.maximum(2.0 - 2.0 * rows @ rows.T, 0.0)
    np.fill_diagonal(squared, 0.0)
    scaled = squared / squared.max(axis=1, keepdims=True)
    hub = hub_discounted_keys(rows, rows, 10, 1.0, exclude=np.eye(40, dtype=bool))
    np.fill_diagonal(hub, -np.inf)
    ranks = np.argsort(hub, axis=1, kind="stable")
    weights, _ = _weights(squared, 5, 3, ranks)
    expected = set_count_weights(scaled, [list(row) for row in ranks], 5, 3)
    assert weights == pytest.approx(expected, abs=1e-12)
    plain, _ = _weights(squared, 5, 3)
    assert not np.allclose(weights, plain)  # the hub order moves some neighbourhoods


def test_a_pool_of_the_whole_catalogue_ranks_as_the_catalogue() -> None:
    rows = unit_rows(50, 8, seed=4)
    exclude = np.eye(50, dtype=bool)
    whole = reciprocal_keys(rows, rescaled_rows(hub_discounted_keys(rows, rows, 10, 1.0,
                                                                    exclude=exclude)))
    radii = neighbourhood_radii(rows, 10, exclude)
    squared = np.maximum(2.0 - 2.0 * rows @ rows.T, 0.0)
    for query in (0, 17, 49):
        others = np.flatnonzero(~exclude[query])
        hub = hub_keys(squared[query, others], radii[query, others])
        assert pool_keys(rows[query], rows[others], hub) == pytest.approx(
            whole[query, others], abs=1e-12)


def planted_group() -> tuple[np.ndarray, np.ndarray]:
    """A query, five classmates around it (0.309 away, on five other axes) and a group of
    eight strung out on one axis, its first two nearer to the query (0.290, 0.304) than any
    classmate, each member's five nearest the group's own."""
    eye = np.eye(16)
    mates = [eye[0] + 0.32 * eye[2 + i] for i in range(5)]
    group = [eye[0] + (0.30 + 0.015 * i) * eye[1] for i in range(8)]
    rows = np.array(mates + group)
    return eye[0], rows / np.linalg.norm(rows, axis=1, keepdims=True)


def test_a_near_group_without_the_query_in_its_nearest_comes_after_the_reciprocal_ones(
) -> None:
    query, candidates = planted_group()
    squared = np.sum((candidates - query) ** 2, axis=1)
    assert list(np.argsort(squared, kind="stable")[:5]) == [5, 6, 0, 1, 2]
    # Without the local expansion (k2 1): the query's five nearest are the group's first
    # two and three classmates; only the classmates have the query among their own five,
    # so they come before the group's second, which follows before the classmates the query
    # does not hold. The group's first is the term's first answer (plain distances here),
    # kept first. (With k2 3 the query's row averages its two nearest's, the group's: the
    # group then stays first, which is why the expansion is small.)
    keys = pool_keys(query, candidates, squared, expansion=1)
    assert list(np.argsort(keys, kind="stable")[:5]) == [5, 0, 1, 2, 6]


def test_the_term_s_first_answer_goes_first_and_the_rest_keep_their_order() -> None:
    keys = np.array([0.5, 0.2, 0.9, -np.inf, 0.4])
    term = np.array([0.1, 0.3, 0.05, -5.0, 0.05])  # the own part's term is not an answer
    kept = first_kept(keys, term)
    assert list(np.argsort(kept, kind="stable")) == [3, 2, 1, 4, 0]  # 2 before 4: a tie
    assert np.array_equal(keys, [0.5, 0.2, 0.9, -np.inf, 0.4])  # the input is not changed
    rows = unit_rows(40, 6, seed=5)
    term = rescaled_rows(hub_discounted_keys(rows, rows, 10, 1.0,
                                             exclude=np.eye(40, dtype=bool)))
    plain = set_count_keys(rows, 5, 3, 0.3, None)  # any keys: the paper's, no answer kept
    kept = first_kept(plain, term)
    for i in range(40):
        others = np.delete(np.arange(40), i)
        first = others[np.argmin(term[i, others])]
        order = others[np.argsort(kept[i, others], kind="stable")]
        assert order[0] == first
        rest = others[np.argsort(plain[i, others], kind="stable")]
        assert list(order[1:]) == [j for j in rest if j != first]


def test_the_query_s_own_part_comes_first_and_does_not_stretch_the_term() -> None:
    rows = unit_rows(30, 6, seed=8)
    query, candidates = rows[0], rows[1:].copy()
    hub = np.sum((candidates - query) ** 2, axis=1) + 0.5
    keys = pool_keys(query, candidates, hub)
    again = candidates.copy()
    again[12] = query  # its own part, among the candidates, far down the hub order
    hub_again = hub.copy()
    hub_again[12] = -3.0  # hub_keys' key for the same part: below every other
    keys_again = pool_keys(query, again, hub_again)
    assert np.argmin(keys_again) == 12 and np.isneginf(keys_again[12])
    # The others' blended term is rescaled over the others alone: only neighbourhoods moved.
    assert np.isfinite(np.delete(keys_again, 12)).all()
    assert np.delete(keys_again, 12).max() <= 1.0 + 1e-12
    assert not np.array_equal(np.delete(keys, 12), np.delete(keys_again, 12))


def test_a_rotation_of_every_vector_changes_no_key() -> None:
    rows = unit_rows(40, 8, seed=21)
    rotation, _ = np.linalg.qr(np.random.default_rng(3).normal(size=(8, 8)))
    assert reciprocal_keys(rows @ rotation) == pytest.approx(reciprocal_keys(rows), abs=1e-9)


@pytest.mark.parametrize("k", [1, 10, 40, 100])
def test_the_service_re_ranks_at_least_the_pool_and_the_hub_depth(k: int) -> None:
    assert reciprocal_depth(k) == max(rerank_depth(k), RECIPROCAL_POOL)
    assert reciprocal_depth(k) >= k


def test_the_re_rank_as_studied_is_the_service_s_without_the_kept_answer() -> None:
    """The selection studies re-run the re-rank as they measured it (``keep_first=False``);
    keeping the term's first answer on top of it gives the service's keys."""
    rows = unit_rows(30, 6, seed=2)
    term = rescaled_rows(hub_discounted_keys(rows, rows, 10, 1.0,
                                             exclude=np.eye(30, dtype=bool)))
    studied = reciprocal_keys(rows, term, keep_first=False)
    assert not np.array_equal(studied, reciprocal_keys(rows, term))
    assert np.array_equal(first_kept(studied, term), reciprocal_keys(rows, term))
