"""Scan-robust retrieval in the evaluator: best-view scoring, boundary weights, virtual views."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from core.evaluation.scan_retrieval import best_entry_distances, boundary_weights, view_subsets
from core.evaluation.scans import scan_of_kind, view_directions, view_kind, virtual_view
from tests.shapes import fibonacci_sphere_points


def test_a_model_scores_its_best_entry_and_appears_once() -> None:
    # Model 0: a whole-model entry far from the query, and a view right next to it.
    # Model 1: one entry at a middling distance. Model 2: no entries at all.
    entries = np.array([[10.0, 0.0], [0.1, 0.0], [3.0, 0.0]])
    owners = np.array([0, 0, 1])
    queries = np.array([[0.0, 0.0], [9.0, 0.0]])
    best = best_entry_distances(queries, entries, owners, models=3)
    assert best.shape == (2, 3)  # one column per model, however many entries it has
    np.testing.assert_allclose(best[0, :2], [0.1, 3.0])
    np.testing.assert_allclose(best[1, :2], [1.0, 6.0])
    assert np.isinf(best[:, 2]).all()
    assert list(np.argsort(best[0])) == [0, 1, 2]


def test_boundary_weights_leave_a_closed_surface_alone() -> None:
    points = fibonacci_sphere_points(3000)
    np.testing.assert_array_equal(boundary_weights(points), 1.0)


def test_boundary_weights_fade_out_towards_the_rim_of_an_open_surface() -> None:
    sphere = fibonacci_sphere_points(6000)
    cap = sphere[sphere[:, 2] > 0.0]  # hemisphere: its rim is the equator
    weights = boundary_weights(cap)
    assert weights[cap[:, 2] < 0.03].max() < 0.2
    assert weights[cap[:, 2] > 0.6].min() == 1.0
    # Non-decreasing with height (distance from the rim), up to sampling jitter.
    bands = [weights[(cap[:, 2] >= lo) & (cap[:, 2] < lo + 0.1)].mean()
             for lo in np.arange(0.0, 0.6, 0.1)]
    assert all(b2 >= b1 - 0.02 for b1, b2 in zip(bands, bands[1:], strict=False))
    noisy = cap + np.random.default_rng(0).normal(scale=0.005, size=cap.shape)
    assert boundary_weights(noisy)[cap[:, 2] > 0.6].mean() > 0.95


def test_virtual_views_see_the_near_cap_from_fixed_spread_directions() -> None:
    directions = view_directions(6)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0)
    angles = np.degrees(np.arccos(np.clip(directions @ directions.T, -1, 1)))
    assert angles[~np.eye(6, dtype=bool)].min() > 60.0
    points = fibonacci_sphere_points(5000)
    view = virtual_view(points, 2, 6)
    # 3 bbox diagonals (2 sqrt 3 each) from the centre: the visible cap is p . d > 1 / D.
    cap_height = 1.0 / (3.0 * 2.0 * np.sqrt(3.0))
    heights = view @ directions[2]
    assert heights.min() > cap_height - 0.06
    # Hidden point removal resolves the horizon to about one sample row (spacing 0.05 here).
    assert len(view) == pytest.approx(np.sum(points @ directions[2] > cap_height), rel=0.05)
    np.testing.assert_array_equal(scan_of_kind(points, np.random.default_rng(0),
                                               view_kind(2, 6)), view)
    with pytest.raises(ValueError):
        scan_of_kind(points, np.random.default_rng(0), "view6of6")


def test_view_subsets_are_all_views_and_spread_smaller_sets() -> None:
    assert view_subsets(6) == [(0, 1, 2, 3, 4, 5), (0, 2, 4), (0, 3)]
    assert view_subsets(2) == [(0, 1)]


def test_merged_virtual_views_are_the_union_of_their_views() -> None:
    points = fibonacci_sphere_points(2000)
    rng = np.random.default_rng(0)
    merged = scan_of_kind(points, rng, "merge01of4")
    union = {tuple(p) for k in (0, 1) for p in virtual_view(points, k, 4)}
    assert {tuple(p) for p in merged} == union
    # Two of four spread views see more than one and less than everything.
    assert len(virtual_view(points, 0, 4)) < len(merged) < len(points)


def test_diagnostic_kinds_split_occlusion_from_noise() -> None:
    points = fibonacci_sphere_points(2000)
    occluded = scan_of_kind(points, np.random.default_rng(1), "multi-nonoise")
    # Occlusion only: a subset of the clean points, exactly, and not all of them.
    assert {tuple(p) for p in occluded} <= {tuple(p) for p in points}
    assert len(occluded) < len(points)
    noisy = scan_of_kind(points, np.random.default_rng(1), "whole-noisy")
    # Noise only: every point (moved) plus 1 % outliers.
    assert len(noisy) == len(points) + round(len(points) * 0.01 / 0.99)
    assert not np.allclose(noisy[: len(points)], points)


def test_cleanup_steps_parse_filters_and_denoising() -> None:
    from core.evaluation.runner import _cleanup_steps

    assert _cleanup_steps("") == (False, None, None, False)
    assert _cleanup_steps("sor+plane16x2") == (True, ("plane", 16, 2), None, False)
    assert _cleanup_steps("mor2.5+quadric24") == (False, ("quadric", 24, 1), 2.5, False)
    assert _cleanup_steps("sor+rev") == (True, None, None, True)
    with pytest.raises(ValueError, match="cleanup"):
        _cleanup_steps("sor+smooth")


@pytest.mark.slow
def test_the_scan_study_runs_end_to_end_on_a_tiny_set(tmp_path: Path) -> None:
    """``run`` describes, caches and scores (a regression guard for the study's plumbing:
    it once read a field that the cutoff record had moved)."""
    import trimesh

    from core.evaluation.scan_retrieval import run

    shapes = {"box": [trimesh.creation.box((1, 2, 3)), trimesh.creation.box((1, 2, 3.3))],
              "cyl": [trimesh.creation.cylinder(1, 4), trimesh.creation.cylinder(1, 4.4)]}
    for label, meshes in shapes.items():
        (tmp_path / "data" / label).mkdir(parents=True)
        for i, mesh in enumerate(meshes):
            mesh.export(tmp_path / "data" / label / f"{label}{i}.stl")
    record = run(tmp_path / "data", tmp_path / "out", per_class=None, views=1,
                 query_kinds=("clean",), points=400)
    assert record["failures"] == [] and record["models"] == 4
    # A box is nearer to the other box than to a cylinder (and so on): every NN is right.
    assert record["scores"]["global|default|clean"]["nn"] == 1.0
    # Catalogues with views are scored in the service's scan-mode order too.
    assert {"views1|default|clean", "views1+hub|default|clean"} <= set(record["scores"])
    assert "global+hub|default|clean" not in record["scores"]


def test_a_rotation_seed_is_a_draw_of_its_own(tmp_path: Path) -> None:
    """The same seed describes a scan bit for bit again; another seed rotates and scans the
    model anew (``scan_retrieval --rotation-seed``)."""
    import trimesh

    from core.eigen import SpectralSolver
    from core.evaluation.dataset import load_dataset
    from core.evaluation.scan_retrieval import describe
    from core.settings import EngineSettings

    (tmp_path / "box").mkdir()
    trimesh.creation.box((1, 2, 3)).export(tmp_path / "box" / "box0.stl")
    model = load_dataset(tmp_path, None).models[0]
    settings = EngineSettings(max_points=400)

    def described(seed: int) -> np.ndarray:
        return describe(model, "single+sor", settings, None, SpectralSolver, ("default",),
                        seed).descriptors["default"]

    np.testing.assert_array_equal(described(1), described(1))
    assert not np.allclose(described(1), described(2))
