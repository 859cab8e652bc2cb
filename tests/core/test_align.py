"""core.compare: one part placed on another, and their deviations, on real parts.

The parts are the fixtures' meshes sampled as the service samples them (``load_points``,
3000 points); "re-sampled" is the same mesh sampled with another seed, so no point of one
sample lies on a point of the other, as between two uploads of one part.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from core.compare import (
    AlignmentBudgetExceeded,
    align,
    compare,
    deviations,
    diagonal,
    rotation_angle,
)
from core.evaluation.scans import ScanSettings, random_rotation, single_view_scan
from core.io import load_points, validate_points
from tests.conftest import PARTS

# Parts without symmetry (their principal spreads are well apart or their shape breaks it).
ASYMMETRIC = ["featuretype.STL", "teapot.stl", "idler_riser.STL"]
SYMMETRIC = ["cylinder.stl", "20mm-xyz-cube.stl", "round.stl"]


def sample(name: str, seed: int = 0, points: int = 3000) -> np.ndarray:
    return load_points(PARTS / name, max_points=points, seed=seed).points


def moved(points: np.ndarray, rotation: np.ndarray, shift: np.ndarray) -> np.ndarray:
    return points @ rotation.T + shift


@pytest.mark.parametrize("name", ASYMMETRIC)
def test_a_part_against_itself_rotated_is_found_within_2_degrees(name: str) -> None:
    rng = np.random.default_rng(len(name))
    a = sample(name)
    size = diagonal(a)
    rotation = random_rotation(rng)
    for b_own in (a, sample(name, seed=7)):  # the same points, then a re-sampling
        b = moved(b_own, rotation, rng.normal(size=3) * size)
        found = compare(a, b)
        # b onto a undoes the rotation: found R = rotation^T.
        assert rotation_angle(found.alignment.rotation @ rotation) <= 2.0
        assert found.deviations.b_to_a.rms <= 0.005 * size
        assert found.deviations.a_to_b.rms <= 0.005 * size
        assert found.deviations.b_to_a.within > 0.95
        assert np.allclose(found.deviations.size_ratios, 1.0, atol=0.02)
        assert abs(found.alignment.scale - 1.0) < 1e-12
        assert np.isclose(np.linalg.det(found.alignment.rotation), 1.0)


def test_the_same_points_rotated_align_exactly() -> None:
    a = sample("featuretype.STL")
    rotation = random_rotation(np.random.default_rng(3))
    found = align(a, moved(a, rotation, np.array([10.0, -4.0, 2.5])))
    assert rotation_angle(found.rotation @ rotation) < 0.01
    assert found.rms < 1e-6 * diagonal(a)


@pytest.mark.slow
@pytest.mark.parametrize("name", SYMMETRIC)
def test_a_symmetric_part_ends_no_worse_than_any_start(name: str) -> None:
    """Its starts are all about equally good: the best final result is kept, so the
    answer is no farther than any start (measured the same way, on every point)."""
    rng = np.random.default_rng(11)
    a = sample(name)
    b = moved(sample(name, seed=7), random_rotation(rng), rng.normal(size=3))
    found = align(a, b)
    assert found.candidates == len(found.starts) >= 24

    def rms(rotation: np.ndarray, shift: np.ndarray, factor: float) -> float:
        return deviations(a, factor * b @ rotation.T + shift, 1.0).b_to_a.rms

    final = rms(found.rotation, found.translation, found.scale)
    starts = [rms(s.rotation, s.translation, s.scale) for s in found.starts]
    assert final <= min(starts)
    assert final <= 0.005 * diagonal(a)


def stretched(points: np.ndarray, share: float) -> tuple[np.ndarray, np.ndarray, float, float]:
    """``points`` with the half beyond the middle of their longest axis stretched, so that
    the end moves by ``share`` of the length; the axis, the middle and the stretch."""
    centre = points.mean(axis=0)
    axis = np.linalg.svd(points - centre, full_matrices=False)[2][0]
    along = (points - centre) @ axis
    middle, end = (along.max() + along.min()) / 2.0, along.max()
    stretch = share * (along.max() - along.min())
    weight = np.clip((along - middle) / (end - middle), 0.0, None)
    return points + np.outer(weight * stretch, axis), axis, middle, stretch


@pytest.mark.parametrize("seed", [0, 7])  # the copy's own points, then a re-sampling
def test_a_copy_with_one_end_stretched_deviates_at_that_end_by_the_stretch(seed: int) -> None:
    a = sample("featuretype.STL")
    copy, axis, middle, stretch = stretched(sample("featuretype.STL", seed=seed), 0.10)
    centre = sample("featuretype.STL", seed=seed).mean(axis=0)
    rng = np.random.default_rng(5)
    found = compare(a, moved(copy, random_rotation(rng), rng.normal(size=3) * 50))
    distances = found.deviations.b_to_a.distances
    worst = distances >= np.quantile(distances, 0.90)
    # The points that deviate most are those of the stretched end, where the copy's own
    # coordinates along the axis lie beyond the middle.
    along = (copy - centre) @ axis
    assert np.mean(along[worst]) > middle
    assert np.mean(along[worst] > middle) > 0.9
    largest = max(found.deviations.b_to_a.max, found.deviations.a_to_b.max)
    assert abs(largest - stretch) <= 0.25 * stretch, (largest, stretch)
    assert found.deviations.size_ratios[0] > 1.05  # longer along the first axis


@pytest.mark.parametrize("other", ["teapot.stl", "angle_block.STL", "cylinder.stl"])
def test_a_different_kind_of_part_is_at_least_5x_farther_than_the_part_itself(
    other: str,
) -> None:
    a = sample("featuretype.STL")
    itself = compare(a, moved(sample("featuretype.STL", seed=7),
                              random_rotation(np.random.default_rng(1)), np.ones(3)))
    # At its best scale too: the shapes differ, not only the sizes.
    different = compare(a, sample(other), scale=True)
    assert different.deviations.b_to_a.rms >= 5 * itself.deviations.b_to_a.rms
    assert different.deviations.a_to_b.rms >= 5 * itself.deviations.a_to_b.rms


@pytest.mark.parametrize(("name", "units"), [("featuretype.STL", 0.001), ("teapot.stl", 25.4)])
def test_a_single_view_scan_in_other_units_is_placed_on_its_part(
    name: str, units: float
) -> None:
    """A scan sees one side (about half) of a closed part, with noise and stray points, in
    units of its own: placed at the part's scale, it lies on the part and covers about
    half of it."""
    rng = np.random.default_rng(2)
    a = sample(name)
    size = diagonal(a)
    view = single_view_scan(sample(name, seed=3, points=20000), rng, ScanSettings())
    rotation = random_rotation(rng)
    scan = validate_points(moved(view * units, rotation, rng.normal(size=3)), max_points=3000,
                           remove_outliers=True)
    found = compare(a, scan, scale=True, partial=True)
    assert found.deviations.b_to_a.rms <= 0.02 * size
    assert 0.25 <= found.deviations.a_to_b.within <= 0.75
    assert abs(found.alignment.scale * units - 1.0) < 0.02
    assert rotation_angle(found.alignment.rotation @ rotation) < 5.0


def test_distances_to_the_surface_leave_out_the_spacing_of_the_samples() -> None:
    """Two samplings of one cube, aligned: their nearest points are about their spacing
    apart; the surfaces they stand for coincide."""
    a = sample("20mm-xyz-cube.stl")
    b = sample("20mm-xyz-cube.stl", seed=7)
    size = diagonal(a)
    points = deviations(a, b, 0.01 * size, metric="point")
    surface = deviations(a, b, 0.01 * size)
    assert points.b_to_a.rms > 0.012 * size and points.b_to_a.within < 0.5
    assert surface.b_to_a.rms < 0.004 * size and surface.b_to_a.within > 0.95
    assert np.all(surface.b_to_a.distances <= points.b_to_a.distances + 1e-12)


def test_the_same_inputs_give_the_same_answer() -> None:
    a, b = sample("teapot.stl"), sample("angle_block.STL")
    first, second = align(a, b, scale=True), align(a, b, scale=True)
    assert np.array_equal(first.rotation, second.rotation)
    assert np.array_equal(first.translation, second.translation)


def test_bad_input_is_refused() -> None:
    a = sample("teapot.stl")
    with pytest.raises(ValueError, match="tolerance"):
        deviations(a, a, 0.0)
    with pytest.raises(ValueError, match="tolerance"):
        compare(a, a, tolerance=-1.0)
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        align(a, a[:, :2])
    with pytest.raises(ValueError, match="non-finite"):
        align(a, np.full((10, 3), np.nan))
    with pytest.raises(ValueError, match="extent"):
        align(a, np.ones((10, 3)))
    with pytest.raises(AlignmentBudgetExceeded):
        align(a, a, deadline=time.monotonic() - 1.0)
