"""The hub discount (``core.rank.hubness``): radii against a direct count, and a hub that a plain
ranking puts first and the discount does not."""

from __future__ import annotations

import numpy as np
import pytest

from core.evaluation.metrics import pairwise_distances
from core.rank.hubness import (
    hub_discounted_keys,
    model_radii,
    model_radii_among,
    neighbourhood_radii,
    scan_hub_keys,
)


def unit_rows(count: int, dims: int, seed: int) -> np.ndarray:
    rows = np.random.default_rng(seed).normal(size=(count, dims))
    return rows / np.linalg.norm(rows, axis=1, keepdims=True)


def direct_radius(rows: np.ndarray, x: int, left_out: int | None, k: int) -> float:
    others = [float(rows[x] @ rows[y]) for y in range(len(rows)) if y not in (x, left_out)]
    return float(np.mean(sorted(others, reverse=True)[:k]))


@pytest.mark.parametrize("k", [1, 3, 7])
def test_radii_are_the_mean_cosine_to_the_k_nearest_others(k: int) -> None:
    rows = unit_rows(30, 6, seed=k)
    radii = neighbourhood_radii(rows, k)
    assert radii == pytest.approx([direct_radius(rows, x, None, k) for x in range(30)])


def test_a_left_out_vector_counts_in_no_radius_of_its_query() -> None:
    rows = unit_rows(25, 5, seed=4)
    rng = np.random.default_rng(5)
    left_out = rng.integers(0, 25, size=12)
    exclude = np.zeros((12, 25), dtype=bool)
    exclude[np.arange(12), left_out] = True
    radii = neighbourhood_radii(rows, 4, exclude)
    expected = [[direct_radius(rows, x, int(left_out[q]), 4) for x in range(25)]
                for q in range(12)]
    # A left-out vector's own radius is never used; it is compared like the others' anyway.
    assert radii == pytest.approx(np.array(expected))
    # Where the left-out vector was among a vector's 4 nearest, its radius changed.
    plain = neighbourhood_radii(rows, 4)
    assert (radii != plain[None, :]).any()


def test_weight_zero_ranks_by_distance_alone() -> None:
    rows = unit_rows(20, 8, seed=1)
    keys = hub_discounted_keys(rows[:5], rows, 4, 0.0)
    distances = pairwise_distances(rows[:5], rows)
    assert keys == pytest.approx(distances**2, abs=1e-9)


def test_the_key_is_csls_order() -> None:
    rows = unit_rows(40, 6, seed=2)
    exclude = np.eye(40, dtype=bool)
    keys = hub_discounted_keys(rows, rows, 5, 1.0, exclude)
    radii = neighbourhood_radii(rows, 5, exclude)
    csls = 2 * rows @ rows.T - radii  # higher first, for each query's row
    for query in range(40):
        others = np.flatnonzero(~exclude[query])
        by_key = others[np.argsort(keys[query, others], kind="stable")]
        by_csls = others[np.argsort(-csls[query, others], kind="stable")]
        assert by_key.tolist() == by_csls.tolist()


def hub_catalogue() -> tuple[np.ndarray, list[str]]:
    """A query ``q`` and its classmate ``a`` (cosine 0.80), a hub ``h`` as near to ``q``
    (0.82) and to six parts of another kind (0.82 each), which are 0.67 from ``q``."""
    basis = np.eye(12)
    side = np.sqrt(1 - 0.82**2)
    hub = basis[0]
    others = [0.82 * basis[0] + side * basis[j] for j in range(1, 7)]
    query = 0.82 * basis[0] + side * basis[7]
    classmate = 0.80 * query + 0.60 * basis[8]
    rows = np.array([query, classmate, hub, *others])
    return rows, ["A", "A", "B", *["B"] * 6]


def test_a_hub_a_plain_ranking_puts_first_comes_after_the_classmate() -> None:
    rows, labels = hub_catalogue()
    assert np.allclose(np.linalg.norm(rows, axis=1), 1.0)
    exclude = np.eye(len(rows), dtype=bool)
    plain = pairwise_distances(rows[:1], rows)[0]
    plain[0] = np.inf
    assert labels[int(np.argmin(plain))] == "B"  # the hub, 0.82 against the classmate's 0.80
    keys = hub_discounted_keys(rows[:1], rows, 3, 1.0, exclude[:1])[0]
    keys[0] = np.inf
    assert int(np.argmin(keys)) == 1  # the classmate: the hub's radius is 0.82, its own 0.58
    radii = neighbourhood_radii(rows, 3, exclude[:1])[0]
    assert radii[2] == pytest.approx(0.82) and radii[1] == pytest.approx(
        (0.80 * 0.82 + 2 * 0.80 * 0.82**2) / 3)


def test_too_small_a_catalogue_is_refused_clearly() -> None:
    rows = unit_rows(2, 3, seed=0)
    with pytest.raises(ValueError, match="at least 3 vectors"):
        hub_discounted_keys(rows, rows, 10, 1.0, np.eye(2, dtype=bool))
    # Three vectors, one left out: each radius is its one remaining neighbour.
    rows = unit_rows(3, 3, seed=0)
    radii = neighbourhood_radii(rows, 10, np.eye(3, dtype=bool))
    assert radii[0, 1] == pytest.approx(float(rows[1] @ rows[2]))


def test_exclude_must_leave_out_at_most_one_vector_per_query() -> None:
    rows = unit_rows(6, 3, seed=0)
    exclude = np.zeros((1, 6), dtype=bool)
    exclude[0, :2] = True
    with pytest.raises(ValueError, match="at most one"):
        neighbourhood_radii(rows, 2, exclude)


def test_model_radii_average_each_other_models_best_cosine() -> None:
    rng = np.random.default_rng(4)
    cosines = rng.uniform(-1, 1, size=(5, 12))
    owners = rng.integers(-1, 6, size=(5, 12))  # -1: not counted
    radii = model_radii(cosines, owners, neighbours=3)
    for row in range(5):
        best: dict[int, float] = {}
        for model, value in zip(owners[row], cosines[row], strict=True):
            if model >= 0:
                best[int(model)] = max(best.get(int(model), -2.0), float(value))
        top = sorted(best.values(), reverse=True)[:3]
        assert radii[row] == pytest.approx(sum(top) / len(top))
    # Fewer models than neighbours average those there are; none gives 0.
    few = model_radii(np.array([[0.9, 0.8, 0.1]]), np.array([[2, 2, -1]]), neighbours=5)
    assert few[0] == pytest.approx(0.9)
    assert model_radii(np.array([[0.9]]), np.array([[-1]]))[0] == 0.0


def test_radii_among_some_entries_bound_the_radii_among_all_from_below() -> None:
    rng = np.random.default_rng(5)
    entries = rng.normal(size=(40, 6))
    entries /= np.linalg.norm(entries, axis=1, keepdims=True)
    owners = np.repeat(np.arange(10), 4)  # 10 models of 4 entries each
    cosines = entries @ entries.T
    hit_owners = np.where(owners[None, :] == owners[:, None], -1, owners[None, :])
    everything = model_radii(cosines, hit_owners, neighbours=3)
    # Among all the entries the bound is the radius itself.
    assert model_radii_among(entries, owners, neighbours=3) == pytest.approx(everything)
    some = owners < 6  # the entries of six models
    bounds = model_radii_among(entries[some], owners[some], neighbours=3)
    assert (bounds <= everything[some] + 1e-12).all() and (bounds < everything[some]).any()
    # Too few other models for a bound: -1, the least a mean cosine can be.
    assert (model_radii_among(entries[:12], owners[:12], neighbours=3) == -1.0).all()
    # The same entries, looking at some of them only (``among``): every entry bounded, the
    # bound looser; and the bounds of a few entries alone (``rows``) are theirs among all.
    looser = model_radii_among(entries, owners, neighbours=3, among=some)
    assert (looser <= everything + 1e-12).all() and (looser < everything - 1e-6).any()
    assert looser[some] == pytest.approx(bounds, abs=1e-12)
    rows = np.array([0, 17, 39])
    assert model_radii_among(entries, owners, neighbours=3, rows=rows) == pytest.approx(
        everything[rows], abs=1e-12)
    assert (model_radii_among(entries, owners, neighbours=3, among=owners < 3) == -1.0).all()


@pytest.mark.parametrize(("models", "k"), [(8, 3), (4, 5)])  # (4, 5): fewer models than k
def test_scan_hub_keys_are_each_models_best_discounted_entry_without_the_left_out(
    models: int, k: int
) -> None:
    rng = np.random.default_rng(6)
    entries = rng.normal(size=(4 * models, 5))
    entries /= np.linalg.norm(entries, axis=1, keepdims=True)
    owners = np.repeat(np.arange(models), 4)
    queries = rng.normal(size=(3, 5))
    queries /= np.linalg.norm(queries, axis=1, keepdims=True)
    left_out = np.array([2, -1, models - 1])
    keys = scan_hub_keys(queries, entries, owners, left_out, neighbours=k, weight=0.5)
    for row, query in enumerate(queries):
        for model in range(models):
            expected = np.inf
            for entry in np.flatnonzero(owners == model):
                best = sorted(
                    (float((entries[owners == other] @ entries[entry]).max())
                     for other in range(models) if other not in (model, left_out[row])),
                    reverse=True,
                )[:k]
                key = float(np.sum((entries[entry] - query) ** 2)) + 0.5 * np.mean(best)
                expected = min(expected, key)
            assert keys[row, model] == pytest.approx(expected)
