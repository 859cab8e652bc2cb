"""Feature-aware sampling (core.evaluation.feature_sampling): the study sampler of issue 24."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from core.evaluation.feature_sampling import feature_weighted_subsample
from core.io._sampling import sample_surface, triangle_areas


def _cube_sample(count: int) -> np.ndarray:
    cube = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    areas = triangle_areas(cube.vertices, cube.faces)
    return sample_surface(cube.vertices, cube.faces, areas, count, seed=3)


def _near_edges(points: np.ndarray, width: float = 0.05) -> np.ndarray:
    """Points within ``width`` of two faces of the unit cube at once (near one of its edges)."""
    margin = 0.5 - np.abs(points)
    return (margin < width).sum(axis=1) >= 2


def test_share_zero_is_a_uniform_draw_and_share_one_favours_edges() -> None:
    dense = _cube_sample(12000)
    uniform = dense[feature_weighted_subsample(dense, 3000, 0.0, seed=1)]
    featured = dense[feature_weighted_subsample(dense, 3000, 0.8, seed=1)]
    everywhere = _near_edges(dense).mean()
    # A uniform draw keeps the dense sample's share of edge points (a binomial spread).
    assert abs(_near_edges(uniform).mean() - everywhere) < 0.03
    # The weighted draw puts well over that share near the cube's edges.
    assert _near_edges(featured).mean() > 2.0 * everywhere


def test_draw_is_deterministic_sorted_and_without_repeats() -> None:
    dense = _cube_sample(4000)
    first = feature_weighted_subsample(dense, 1000, 0.5, seed=7)
    again = feature_weighted_subsample(dense, 1000, 0.5, seed=7)
    other = feature_weighted_subsample(dense, 1000, 0.5, seed=8)
    assert np.array_equal(first, again)
    assert not np.array_equal(first, other)
    assert len(np.unique(first)) == 1000 and np.all(np.diff(first) > 0)


def test_small_inputs_are_kept_whole_and_bad_shares_refused() -> None:
    dense = _cube_sample(500)
    assert np.array_equal(feature_weighted_subsample(dense, 800, 0.5, seed=0), np.arange(500))
    with pytest.raises(ValueError, match="share"):
        feature_weighted_subsample(dense, 100, 1.5, seed=0)


def test_a_feature_aware_sampling_has_its_own_cache_and_is_for_clean_samples_only() -> None:
    from core.evaluation.runner import sampling_of
    from core.settings import EngineSettings

    settings = EngineSettings()
    uniform = sampling_of(settings, rotation_seed=1)
    featured = sampling_of(settings, rotation_seed=1, feature_share=0.5)
    # Eigenpairs of one sampling must never be served for the other.
    assert uniform.cache_name("ab" * 32) != featured.cache_name("ab" * 32)
    with pytest.raises(ValueError, match="clean"):
        sampling_of(settings, rotation_seed=1, scan="single", feature_share=0.5)
