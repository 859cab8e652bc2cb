"""``describe`` end to end: the invariances a search descriptor must have.

Tolerances are documented here once. Distances are L2 between unit-norm descriptors (so in
[0, 2]); ``SAME_SHAPE`` bounds the distance between two descriptions of one shape under a
rigid motion, scaling or re-ordering, and the distance to a different part must be many
times larger.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import trimesh

from core.errors import InvalidShapeError
from core.pipeline import describe, describe_points
from core.settings import EngineSettings

FIXTURES = Path(__file__).parents[1] / "fixtures" / "parts"
# Observed: below 1e-3 for rigid copies; re-ordering the points perturbs the solver start.
SAME_SHAPE = 0.02
SETTINGS = EngineSettings(max_points=3000)


def distance(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a.astype(np.float64) - b.astype(np.float64)))


def sampled_part(name: str, count: int, seed: int = 0) -> np.ndarray:
    mesh = trimesh.load(FIXTURES / name, force="mesh")
    points, _ = trimesh.sample.sample_surface(mesh, count, seed=seed)
    return np.asarray(points)


def random_rotation(seed: int) -> np.ndarray:
    matrix, _ = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))
    return matrix * np.sign(np.linalg.det(matrix))


@pytest.fixture(scope="module")
def reference() -> tuple[np.ndarray, np.ndarray]:
    points = sampled_part("idler_riser.STL", 3000)
    return points, describe_points(points, SETTINGS).descriptor


@pytest.fixture(scope="module")
def other_part() -> np.ndarray:
    return describe_points(sampled_part("teapot.stl", 3000), SETTINGS).descriptor


@pytest.mark.slow
@pytest.mark.parametrize(
    "transform",
    [
        pytest.param(lambda p: p @ random_rotation(1).T, id="rotation"),
        pytest.param(lambda p: p + np.array([120.0, -40.0, 7.5]), id="translation"),
        pytest.param(lambda p: 3.7 * p, id="uniform-scale"),
        pytest.param(lambda p: p[np.random.default_rng(2).permutation(len(p))], id="point-order"),
        pytest.param(lambda p: 0.01 * (p @ random_rotation(3).T) - 5.0, id="all-at-once"),
    ],
)
def test_descriptor_is_invariant(reference, other_part, transform) -> None:
    points, descriptor = reference
    moved = describe_points(transform(points), SETTINGS).descriptor
    assert distance(moved, descriptor) < SAME_SHAPE
    assert distance(other_part, descriptor) > 5 * SAME_SHAPE


@pytest.mark.slow
def test_describe_file_matches_describe_bytes() -> None:
    path = FIXTURES / "angle_block.STL"
    from_path = describe(path, SETTINGS)
    from_bytes = describe(path.read_bytes(), SETTINGS, filename="angle_block.STL")
    np.testing.assert_array_equal(from_path.descriptor, from_bytes.descriptor)
    assert from_path.format == "stl"
    assert from_path.n_points == 3000
    assert set(from_path.timings) >= {"load", "laplacian", "eigensolve", "signature", "total"}


@pytest.mark.slow
def test_description_is_consistent() -> None:
    description = describe(FIXTURES / "cylinder.stl", SETTINGS)
    cutoff = description.cutoff
    assert SETTINGS.cutoff.n_min <= cutoff.n <= SETTINGS.cutoff.n_max
    assert description.eigenvalues.shape == (cutoff.n,)
    assert cutoff.eigenvalues.size >= cutoff.n
    assert np.all(np.diff(description.eigenvalues) >= -1e-9)
    assert abs(description.eigenvalues[0]) < 1e-6  # the constant mode
    assert description.areas.sum() == pytest.approx(1.0)
    assert description.signature.shape[0] == description.n_points
    # Unit area: Weyl's law puts lambda_n near 4 pi n for any surface.
    weyl = description.eigenvalues[-1] / (4 * np.pi * (cutoff.n - 1))
    assert 0.6 < weyl < 1.6


# Parts whose walls are thicker than the Laplacian's neighbourhood at 5k points (about 0.05 of
# the unit-area scale with 40 neighbours). Thinner walls (plate_holes, idler_riser) are bridged
# at 5k but not at 20k: their low spectrum moves by 10-20 %, a resolution limit of every
# k-nearest-neighbour Laplacian that the README states; mesh uploads are always sampled at
# max_points, so it only concerns sparse scans.
RESOLVED_AT_5K = ("teapot.stl", "round.stl", "cylinder.stl")


@pytest.fixture(scope="module")
def resampled() -> dict[tuple[str, int], object]:
    settings = replace(SETTINGS, max_points=20000)
    names = (*RESOLVED_AT_5K, "angle_block.STL", "octagonal_pocket.stl")
    return {
        (name, count): describe_points(sampled_part(name, count, seed=count), settings)
        for name in names
        for count in (5000, 20000)
    }


@pytest.mark.slow
@pytest.mark.parametrize("name", RESOLVED_AT_5K)
def test_resampling_keeps_cutoff_and_descriptor(resampled, name: str) -> None:
    coarse, fine = resampled[(name, 5000)], resampled[(name, 20000)]
    assert abs(coarse.cutoff.n - fine.cutoff.n) <= 0.15 * max(coarse.cutoff.n, fine.cutoff.n)
    same = distance(coarse.descriptor, fine.descriptor)
    others = [
        distance(description.descriptor, other.descriptor)
        for (other_name, _), other in resampled.items()
        if other_name != name
        for description in (coarse, fine)
    ]
    assert same < 0.6 * min(others)


@pytest.mark.slow
def test_outlier_filter_keeps_scan_outliers_out_of_the_descriptor(reference, other_part) -> None:
    points, clean = reference
    rng = np.random.default_rng(4)
    low, high = points.min(axis=0), points.max(axis=0)
    strays = rng.uniform(low, high, size=(len(points) // 100, 3))  # 1 % outliers in the box
    scan = np.vstack([points, strays])
    filtered = describe_points(scan, SETTINGS).descriptor
    unfiltered = describe_points(scan, replace(SETTINGS, outlier_filter=False)).descriptor
    assert distance(filtered, clean) < 0.5 * distance(unfiltered, clean)
    assert distance(filtered, clean) < 0.5 * distance(other_part, clean)


def test_fixed_cutoff_uses_exactly_n() -> None:
    from core.settings import CutoffSettings

    settings = replace(SETTINGS, cutoff=CutoffSettings(mode="fixed", n=60))
    description = describe(FIXTURES / "cylinder.stl", settings)
    assert description.cutoff.n == 60
    assert description.cutoff.solver_calls == 1
    assert description.eigenvalues.shape == (60,)


@pytest.mark.parametrize("content", [b"", b"not a mesh at all", b"1 2 3\nnan 4 5\n" * 200])
def test_bad_input_raises_the_documented_error(content: bytes) -> None:
    with pytest.raises(InvalidShapeError):
        describe(content, SETTINGS, filename="upload.xyz")


def test_degenerate_points_raise_the_documented_error() -> None:
    line = np.outer(np.linspace(0, 1, 500), [1.0, 2.0, 3.0])
    with pytest.raises(InvalidShapeError) as raised:
        describe_points(line, SETTINGS)
    assert raised.value.reason == "degenerate"


@pytest.mark.slow
def test_a_clean_cloud_export_is_described_like_its_mesh(tmp_path: Path) -> None:
    # The engine's own sample of the mesh, uploaded as an .xyz: the outlier filter must keep
    # every point (the former mean + 2 std rule dropped 3-4 % of them, opening holes).
    from core.io import load_points

    mesh_path = FIXTURES / "angle_block.STL"
    sampled = load_points(mesh_path, max_points=SETTINGS.max_points).points
    cloud = tmp_path / "angle_block.xyz"
    np.savetxt(cloud, sampled, fmt="%.17g")
    as_cloud = describe(cloud, SETTINGS)
    assert as_cloud.n_points == len(sampled)
    assert distance(as_cloud.descriptor, describe(mesh_path, SETTINGS).descriptor) < 1e-3
