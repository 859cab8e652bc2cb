"""Completing a partial view about its axis of revolution (``core.evaluation.revolution``,
measured for scan mode and declined; the study's ``+rev`` step): the axis
of a turned part's half view is found, other shapes do not agree with theirs, and the
completed view is the whole surface."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from core.evaluation.revolution import fit_axis, revolve
from core.evaluation.scans import random_rotation
from core.views import hidden_point_removal


def surface(mesh: trimesh.Trimesh, count: int = 6000) -> np.ndarray:
    points, _ = trimesh.sample.sample_surface(mesh, count, seed=3)
    return np.asarray(points)


def half_view(points: np.ndarray) -> np.ndarray:
    """What a viewpoint off to one side sees (about half of a turned part)."""
    viewpoint = points.mean(axis=0) + np.array([6.0, 1.0, 0.5]) * np.ptp(points, axis=0).max()
    return points[hidden_point_removal(points, viewpoint)]


def stepped_shaft() -> trimesh.Trimesh:
    """A turned part: a shaft with a wider collar, axis z (one closed surface)."""
    profile = [(0.0, -1.5), (0.4, -1.5), (0.4, 0.6), (0.8, 0.6), (0.8, 1.2), (0.4, 1.2),
               (0.4, 1.5), (0.0, 1.5)]
    return trimesh.creation.revolve(np.array(profile), sections=96)


def angle_degrees(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(min(1.0, abs(float(a @ b))))))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_axis_of_a_half_view_of_a_turned_part_is_found(seed: int) -> None:
    rng = np.random.default_rng(seed)
    rotation = random_rotation(rng)
    shift = rng.normal(size=3) * 5.0
    view = half_view(surface(stepped_shaft()) @ rotation.T + shift)
    axis = fit_axis(view)
    assert angle_degrees(axis.direction, rotation[:, 2]) < 2.0
    # The fitted axis passes through the true one (shift is a point of it).
    offset = (axis.origin - shift) - ((axis.origin - shift) @ rotation[:, 2]) * rotation[:, 2]
    assert np.linalg.norm(offset) < 0.05
    assert axis.agreement > 0.9


@pytest.mark.parametrize(
    "mesh",
    [trimesh.creation.box([1.0, 2.0, 3.0]), trimesh.creation.cylinder(1.0, 0.8, sections=6)],
    ids=["box", "hex prism"],
)
def test_shapes_that_are_not_turned_do_not_agree_with_an_axis(mesh: trimesh.Trimesh) -> None:
    assert fit_axis(half_view(surface(mesh))).agreement < 0.3


def test_a_plate_is_not_taken_for_a_disc() -> None:
    # Every normal of a flat face runs along any axis normal to it: those points are not
    # counted as agreeing, and the plate's thin rim does not agree either.
    plate = trimesh.creation.box([3.0, 3.0, 0.3])
    assert fit_axis(half_view(surface(plate))).agreement < 0.3


def test_agreement_is_invariant_to_rotation_translation_scale_and_order() -> None:
    view = half_view(surface(stepped_shaft()))
    reference = fit_axis(view)
    rng = np.random.default_rng(7)
    moved = (view @ random_rotation(rng).T) * 3.5 + np.array([10.0, -4.0, 2.0])
    moved = moved[rng.permutation(len(moved))]
    assert fit_axis(moved).agreement == pytest.approx(reference.agreement, abs=0.01)


def test_the_completed_half_view_is_the_whole_turned_surface() -> None:
    whole = surface(stepped_shaft(), 12000)
    view = half_view(whole)
    completed = revolve(view, fit_axis(view), 6000, seed=0)
    # Every completed point lies on the part.
    on_part, _ = cKDTree(whole).query(completed)
    assert np.quantile(on_part, 0.95) < 0.05
    # The completion reaches all of the turned sides (the cylinders; the flat end faces the
    # view hardly saw cannot be completed), where the half view leaves the far side out.
    radius = np.linalg.norm(whole[:, :2], axis=1)
    sides = whole[(np.abs(radius - 0.4) < 0.005) | (np.abs(radius - 0.8) < 0.005)]
    reach_view, _ = cKDTree(view).query(sides)
    reach_completed, _ = cKDTree(completed).query(sides)
    assert np.quantile(reach_view, 0.9) > 0.3
    assert np.quantile(reach_completed, 0.9) < 0.08


def test_revolve_is_deterministic_and_keeps_each_points_height_and_radius() -> None:
    view = half_view(surface(stepped_shaft()))
    axis = fit_axis(view)
    first = revolve(view, axis, 2000, seed=5)
    assert np.array_equal(first, revolve(view, axis, 2000, seed=5))
    assert not np.array_equal(first, revolve(view, axis, 2000, seed=6))

    def cylindrical(points: np.ndarray) -> np.ndarray:
        relative = points - axis.origin
        along = relative @ axis.direction
        radius = np.linalg.norm(relative - along[:, None] * axis.direction, axis=1)
        return np.column_stack([along, radius])

    distance, _ = cKDTree(cylindrical(view)).query(cylindrical(first))
    assert distance.max() < 1e-9
