"""Scan mode's order (``core.rank.scan_order``): the first answer by the scan hub keys, the rest
of the pool as a shape query for that answer orders it, against a direct computation, and
the kind of the first answer before a nearer other kind."""

from __future__ import annotations

import numpy as np

from core.rank.hubness import HUB_NEIGHBOURS, hub_keys, neighbourhood_radii, scan_hub_keys
from core.rank.reciprocal import pool_keys
from core.rank.scan_order import scan_mode_positions, scan_ranking
from tests.core.test_hubness import direct_radius, unit_rows


def ranked(positions: np.ndarray) -> list[int]:
    """The models of finite position, first to last."""
    return [int(i) for i in np.argsort(positions, kind="stable") if np.isfinite(positions[i])]


def keyed_catalogue(models: int, left_out: int, seed: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``models`` random unit whole descriptors ``(m, 6)``, random scan keys ``(m,)`` (``inf``
    for the ``left_out`` model) and each model's shape-mode radius ``(m,)`` without it."""
    whole = unit_rows(models, 6, seed=seed)
    keys = np.random.default_rng(seed).uniform(0.5, 2.0, size=models)
    keys[left_out] = np.inf
    excluded = np.zeros((1, models), dtype=bool)
    excluded[0, left_out] = True
    return whole, keys, neighbourhood_radii(whole, HUB_NEIGHBOURS, exclude=excluded)[0]


def test_scan_ranking_keeps_the_first_answer_and_orders_its_pool_as_the_first_answers_query(
) -> None:
    whole, keys, radii = keyed_catalogue(30, left_out=7, seed=4)
    positions = scan_ranking(keys, whole, depth=12, radii=radii, neighbours=0)
    order = ranked(positions)
    by_key = [int(i) for i in np.argsort(keys, kind="stable") if np.isfinite(keys[i])]
    assert order[0] == by_key[0] and 7 not in order and positions[7] == np.inf
    assert len(order) == 29
    # The rest of the pool: the shape query for the first answer's whole descriptor.
    anchor, rest = by_key[0], np.array(by_key[1:12])
    radius = [direct_radius(whole, int(x), 7, HUB_NEIGHBOURS) for x in rest]
    squared = np.sum((whole[rest] - whole[anchor]) ** 2, axis=1)
    near = pool_keys(whole[anchor], whole[rest], hub_keys(squared, np.array(radius)))
    assert order[1:12] == [int(i) for i in rest[np.argsort(near, kind="stable")]]
    assert order[12:] == by_key[12:]  # beyond the pool: by key
    assert order[1:12] != by_key[1:12]  # the first answer's order moved something


def test_scan_ranking_joins_the_first_answers_nearest_models_to_its_pool() -> None:
    """The first answer's 6 nearest by whole descriptor (not a left-out model) join the
    pool of 8, and the shape query for it orders them all; the others follow by key."""
    whole, keys, radii = keyed_catalogue(40, left_out=3, seed=5)
    order = ranked(scan_ranking(keys, whole, depth=8, radii=radii, neighbours=6))
    by_key = [int(i) for i in np.argsort(keys, kind="stable") if np.isfinite(keys[i])]
    anchor = by_key[0]
    distances = np.linalg.norm(whole - whole[anchor], axis=1)
    near = [int(i) for i in np.argsort(distances, kind="stable") if i not in (anchor, 3)][:6]
    joined = by_key[1:8] + [i for i in near if i not in by_key[:8]]
    assert len(joined) > 7  # some of the nearest were beyond the pool
    rest = np.array(joined)
    radius = [direct_radius(whole, int(x), 3, HUB_NEIGHBOURS) for x in rest]
    squared = np.sum((whole[rest] - whole[anchor]) ** 2, axis=1)
    keys_of_rest = pool_keys(whole[anchor], whole[rest], hub_keys(squared, np.array(radius)))
    head = [anchor, *(int(i) for i in rest[np.argsort(keys_of_rest, kind="stable")])]
    assert order[: len(head)] == head
    assert order[len(head):] == [i for i in by_key if i not in head]
    assert 3 not in order


def test_scan_mode_positions_rank_each_query_without_its_own_model() -> None:
    entries = unit_rows(36, 5, seed=6)
    owners = np.repeat(np.arange(12), 3)
    whole = entries[::3]
    queries = unit_rows(4, 5, seed=7)
    left_out = np.array([2, -1, 5, 0])
    positions = scan_mode_positions(queries, entries, owners, left_out, whole, depth=6)
    keys = scan_hub_keys(queries, entries, owners, left_out)
    for row, model in enumerate(left_out):
        expected_keys = keys[row].copy()
        excluded = np.zeros((1, 12), dtype=bool)
        if model >= 0:
            expected_keys[model] = np.inf
            excluded[0, model] = True
            assert positions[row, model] == np.inf
        radii = neighbourhood_radii(whole, HUB_NEIGHBOURS, exclude=excluded)[0]
        np.testing.assert_array_equal(positions[row],
                                      scan_ranking(expected_keys, whole, 6, radii))
    assert np.isfinite(positions[1]).all()


def test_the_first_answers_kind_comes_before_another_kind_nearer_the_scan() -> None:
    """Two kinds of five models, each whole near its kind's centre; the scan meets one model
    of kind A best, and kind B's models a little better than A's others (their keys are
    lower). The first answer is A's, and the rest of A follow it before any of B."""
    d = 12
    basis = np.eye(d)
    rng = np.random.default_rng(3)

    def unit(row: np.ndarray) -> np.ndarray:
        return row / np.linalg.norm(row)

    whole = np.array([unit(basis[0] + 0.2 * rng.normal(size=d)) for _ in range(5)]
                     + [unit(basis[1] + 0.2 * rng.normal(size=d)) for _ in range(5)])
    keys = np.array([0.2, 0.9, 0.95, 1.0, 1.05, 0.5, 0.55, 0.6, 0.65, 0.7])
    radii = neighbourhood_radii(whole, 3)
    order = ranked(scan_ranking(keys, whole, depth=10, radii=radii))
    assert order[0] == 0
    assert set(order[1:5]) == {1, 2, 3, 4} and set(order[5:]) == {5, 6, 7, 8, 9}
    by_key = [int(i) for i in np.argsort(keys, kind="stable")]
    assert set(by_key[1:6]) == {5, 6, 7, 8, 9}  # what the keys alone would give
