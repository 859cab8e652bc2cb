"""The depth-sensor turntable scans of the evaluation, checked against a sphere's geometry."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial import cKDTree

from core.evaluation.scans import (
    ScanSettings,
    SensorSettings,
    hidden_point_removal,
    missing_patch_mask,
    scan_of_kind,
    sensor_depth,
    sensor_scan,
    simulate_scan,
    turntable_viewpoints,
)
from tests.shapes import fibonacci_sphere_points

#: A perfect sensor: no noise, no quantisation, no patches, no registration error, no outliers.
EXACT = SensorSettings(depth_step=0.0, depth_noise=0.0, missing_patches=0, registration=0.0,
                       outliers=0.0)


def _seen(scan: np.ndarray, surface: np.ndarray) -> np.ndarray:
    """``(n,)`` bool: which surface points reappear (exactly) in the scan."""
    distance, index = cKDTree(scan).query(surface)
    return distance < 1e-9


def test_hidden_point_removal_sees_exactly_the_near_hemisphere_from_far_away() -> None:
    points = fibonacci_sphere_points(4000)
    direction = np.array([0.3, -0.5, 0.81])
    direction /= np.linalg.norm(direction)
    visible = np.zeros(len(points), dtype=bool)
    visible[hidden_point_removal(points, 1e4 * direction)] = True
    height = points @ direction
    spacing = np.sqrt(4.0 * np.pi / len(points))  # between neighbouring samples
    # The horizon is resolved to one sample spacing: the hull may take in the first row past
    # it, never more.
    assert not visible[height < -spacing].any()  # nothing of the far side
    assert visible[height > spacing].all()  # all of the near side
    assert abs(visible.mean() - 0.5) < 0.02


def test_depth_is_quantised_along_each_ray_in_steps_growing_with_depth_squared() -> None:
    rng = np.random.default_rng(0)
    camera, target = np.zeros(3), np.array([0.0, 0.0, 1.0])
    points = np.column_stack([rng.uniform(-0.3, 0.3, (5000, 2)), rng.uniform(0.8, 2.0, 5000)])
    measured = sensor_depth(points, camera, target, rng, reference=1.0, step=0.01, noise=0.0)
    true_depth, depth = points[:, 2], measured[:, 2]
    step = 0.01 * true_depth**2
    assert np.allclose(depth / step, np.round(depth / step), atol=1e-6)
    assert np.all(np.abs(depth - true_depth) <= step / 2 + 1e-12)
    # Same pixel: the measured point is on the original ray.
    rays = points / np.linalg.norm(points, axis=1, keepdims=True)
    assert np.allclose(np.cross(rays, measured), 0.0, atol=1e-12)


def test_depth_noise_has_the_set_deviation_and_grows_with_depth_squared() -> None:
    rng = np.random.default_rng(1)
    camera, target = np.zeros(3), np.array([0.0, 0.0, 1.0])
    for depth, expected in ((1.0, 0.002), (2.0, 0.008)):
        points = np.column_stack([np.zeros((20000, 2)), np.full(20000, depth)])
        measured = sensor_depth(points, camera, target, rng, reference=1.0, step=0.0,
                                noise=0.002)
        assert np.std(measured[:, 2] - depth) == pytest.approx(expected, rel=0.03)


def test_missing_patches_are_balls_of_the_given_radius() -> None:
    points = fibonacci_sphere_points(20000)
    assert missing_patch_mask(points, np.random.default_rng(0), 0, 0.3).all()
    keep = missing_patch_mask(points, np.random.default_rng(0), 1, 0.3)
    removed = points[~keep]
    spread = np.linalg.norm(removed[:, None] - removed[None], axis=2).max()
    assert spread <= 0.6
    # A chord radius rho cuts a cap of height rho^2 / 2 from the unit sphere: area share rho^2/4.
    assert (~keep).mean() == pytest.approx(0.3**2 / 4, rel=0.05)


def _expected_turntable_coverage(points: np.ndarray, settings: SensorSettings) -> np.ndarray:
    """Points of a unit sphere some camera sees: (p - c) . (v - c) > r^2, above the clip."""
    seen = np.zeros(len(points), dtype=bool)
    for camera in turntable_viewpoints(points, settings.views, settings):
        seen |= points @ camera > 1.0
    diagonal = 2.0 * np.sqrt(3.0)  # bounding box of the unit sphere
    clip = settings.table_clip * diagonal / settings.object_size
    return seen & (points[:, 2] > -1.0 + clip)


def test_turntable_coverage_matches_the_union_of_the_cameras_caps() -> None:
    points = fibonacci_sphere_points(8000)
    scan = sensor_scan(points, np.random.default_rng(2), EXACT)
    seen = _seen(scan, points)
    expected = _expected_turntable_coverage(points, EXACT)
    # The random phase of the turntable moves the caps by up to 10 degrees of azimuth; with
    # 18 views their union hardly changes.
    assert abs(seen.mean() - expected.mean()) < 0.02
    assert np.mean(seen == expected) > 0.97
    # The cameras are above the table: the bottom is never seen and the top always is.
    assert not seen[points[:, 2] < -0.9].any()
    assert seen[points[:, 2] > 0.9].all()
    single = _seen(sensor_scan(points, np.random.default_rng(2), EXACT, views=1), points)
    assert 0.3 < single.mean() < 0.5 < seen.mean()


def test_turntable_scan_keeps_the_outlier_share() -> None:
    points = fibonacci_sphere_points(4000)
    settings = replace(EXACT, outliers=0.05)
    scan = sensor_scan(points, np.random.default_rng(3), settings)
    off_surface = np.abs(np.linalg.norm(scan, axis=1) - 1.0) > 1e-6
    assert off_surface.mean() == pytest.approx(0.05, abs=0.002)


def test_sensor_noise_and_quantisation_are_about_a_centimetre_at_object_scale() -> None:
    points = fibonacci_sphere_points(4000)
    settings = replace(SensorSettings(), missing_patches=0, outliers=0.0)
    scan = sensor_scan(points, np.random.default_rng(4), settings)
    metre = 2.0 * np.sqrt(3.0) / settings.object_size
    radial = (np.linalg.norm(scan, axis=1) - 1.0) / metre  # metres
    # Quantisation (~1 cm steps, uniform error of std 1/sqrt(12) cm) plus noise and
    # registration: a few millimetres, not centimetres.
    assert 0.002 < np.std(radial) < 0.006
    assert np.abs(radial).max() < 0.03


def test_scan_kinds_keep_the_original_simulator_and_are_seeded() -> None:
    points = fibonacci_sphere_points(3000)
    for kind, views in (("single", 1), ("multi", 3)):
        old = simulate_scan(points, np.random.default_rng(5), ScanSettings(), views=views)
        np.testing.assert_array_equal(scan_of_kind(points, np.random.default_rng(5), kind), old)
    first = scan_of_kind(points, np.random.default_rng(6), "kinect-view")
    again = scan_of_kind(points, np.random.default_rng(6), "kinect-view")
    np.testing.assert_array_equal(first, again)
    with pytest.raises(ValueError, match="unknown scan kind"):
        scan_of_kind(points, np.random.default_rng(0), "lidar")
