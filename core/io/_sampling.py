"""Turning meshes into points and thinning large clouds, both reproducibly.

* ``sample_surface``: area-weighted random points on the triangles of a mesh, drawn from
  ``np.random.default_rng(seed)``, so the same file always gives the same points.
* ``voxel_downsample``: thin a cloud to exactly ``target`` points spread evenly over its
  surface: one representative per occupied voxel of a grid whose cell size is searched so that
  about ``target`` voxels are occupied, then a seeded trim to the exact count. Dense regions of
  a scan therefore lose more points than sparse ones, which taking the first rows or a uniform
  random subset would not do.
"""

from __future__ import annotations

import numpy as np

__all__ = ["sample_surface", "triangle_areas", "voxel_downsample"]

# Faces are processed in chunks so that a big mesh never needs an (n_faces, 3, 3) copy at once.
_FACE_CHUNK = 1_000_000
# Voxel counts within this fraction above the target end the cell-size search; the rest is
# trimmed at random, which removes too few points to make the result noticeably uneven.
_COUNT_TOLERANCE = 0.10
_MAX_SEARCH_STEPS = 14
# Finest grid: 2**20 cells along the longest side, so that three cell indices pack into one
# int64 key (60 bits) and a sort of one integer column counts the occupied voxels.
_FINEST_CELLS = 2**20


def triangle_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area of every triangle.

    Parameters
    ----------
    vertices : (v, 3) float
    faces : (f, 3) int
        Indices into ``vertices``, all valid.

    Returns
    -------
    (f,) float
    """
    areas = np.empty(len(faces), dtype=np.float64)
    for start in range(0, len(faces), _FACE_CHUNK):
        chunk = faces[start : start + _FACE_CHUNK]
        a, b, c = (vertices[chunk[:, i]] for i in range(3))
        areas[start : start + len(chunk)] = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    return areas


def sample_surface(
    vertices: np.ndarray, faces: np.ndarray, areas: np.ndarray, n: int, seed: int
) -> np.ndarray:
    """Draw points uniformly over the area of a triangle mesh.

    Parameters
    ----------
    vertices : (v, 3) float
    faces : (f, 3) int
    areas : (f,) float
        ``triangle_areas(vertices, faces)``; their sum must be positive.
    n : int
        Number of points to draw.
    seed : int
        Seed of ``np.random.default_rng``; same inputs and seed give identical points.

    Returns
    -------
    (n, 3) float
    """
    rng = np.random.default_rng(seed)
    cdf = np.cumsum(areas)
    # side="right" never picks a zero-area face: its cdf step is empty.
    picked = np.searchsorted(cdf, rng.random(n) * cdf[-1], side="right")
    picked = np.minimum(picked, len(faces) - 1)
    u, v = rng.random((2, n))
    # Points with u + v > 1 fall in the other half of the parallelogram: fold them back.
    outside = u + v > 1.0
    u[outside], v[outside] = 1.0 - u[outside], 1.0 - v[outside]
    tri = faces[picked]
    a, b, c = (vertices[tri[:, i]] for i in range(3))
    return a + u[:, None] * (b - a) + v[:, None] * (c - a)


def _voxel_keys(offsets: np.ndarray, extent: np.ndarray, size: float) -> np.ndarray:
    """One int64 key per point naming its voxel of edge ``size``.

    Parameters
    ----------
    offsets : (n, 3) float
        Points minus the minimum corner of their bounding box (all >= 0).
    extent : (3,) float
        ``offsets.max(axis=0)``.
    size : float
        Voxel edge, at least ``extent.max() / _FINEST_CELLS``.

    Returns
    -------
    (n,) int64
    """
    # Truncation is floor here because every offset is >= 0.
    cells = (offsets * (1.0 / size)).astype(np.int64)
    dims = (extent * (1.0 / size)).astype(np.int64) + 1
    return (cells[:, 0] * dims[1] + cells[:, 1]) * dims[2] + cells[:, 2]


def _count_distinct(keys: np.ndarray) -> int:
    # Sort and count steps: much faster than np.unique for one int64 column.
    ordered = np.sort(keys)
    return int(np.count_nonzero(ordered[1:] != ordered[:-1])) + 1


def _cell_size(offsets: np.ndarray, extent: np.ndarray, target: int) -> float:
    """Voxel edge with at least ``target`` occupied voxels, and not many more.

    Searches log(size) between the finest grid and one cell over the whole box, interpolating
    log(count) against log(size) (count ~ size**-d for a d-dimensional set) and keeping the
    guess away from the bracket ends so that the search cannot stall on one side.
    """
    longest = float(extent.max())
    lo, hi = longest / _FINEST_CELLS, longest * 1.01
    count_lo, count_hi = _count_distinct(_voxel_keys(offsets, extent, lo)), 1
    if count_lo <= target:
        # So clustered that even the finest grid has too few voxels; the caller tops up.
        return lo
    for _ in range(_MAX_SEARCH_STEPS):
        span = np.log(hi / lo)
        slope = np.log(count_lo / count_hi) / span
        step = min(max(np.log(count_lo / target) / slope / span, 0.1), 0.9)
        size = lo * (hi / lo) ** step
        count = _count_distinct(_voxel_keys(offsets, extent, size))
        if count >= target:
            lo, count_lo = size, count
            if count <= target * (1.0 + _COUNT_TOLERANCE):
                break
        else:
            hi, count_hi = size, max(count, 1)
    return lo


def _representatives(points: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Per occupied voxel, the index of the point nearest the centroid of the voxel's points.

    Parameters
    ----------
    points : (n, 3) float
    keys : (n,) int64
        Voxel of every point.

    Returns
    -------
    (m,) int
        One index per occupied voxel, in voxel-key order. Deterministic for a given ``points``
        array (a stable sort; the first of equally near points wins).
    """
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    starts = np.flatnonzero(np.r_[True, sorted_keys[1:] != sorted_keys[:-1]])
    group = np.cumsum(np.r_[True, sorted_keys[1:] != sorted_keys[:-1]]) - 1
    sorted_points = points[order]
    counts = np.diff(np.r_[starts, len(order)])
    centroids = np.add.reduceat(sorted_points, starts, axis=0) / counts[:, None]
    dist2 = ((sorted_points - centroids[group]) ** 2).sum(axis=1)
    nearest = dist2 == np.minimum.reduceat(dist2, starts)[group]
    candidates = np.flatnonzero(nearest)
    first = candidates[np.r_[True, group[candidates[1:]] != group[candidates[:-1]]]]
    return order[first]


def voxel_downsample(points: np.ndarray, target: int, seed: int) -> np.ndarray:
    """Thin a point cloud to exactly ``target`` points spread evenly over it.

    Parameters
    ----------
    points : (n, 3) float
        Distinct, finite points with ``n > target``, in an order that does not depend on the
        file (``validate_points`` passes them sorted), so that the result does not either.
    target : int
        Number of points to keep.
    seed : int
        Seed of the trim to the exact count.

    Returns
    -------
    (target,) int
        Indices into ``points`` of the kept points.
    """
    offsets = points - points.min(axis=0)
    extent = offsets.max(axis=0)
    size = _cell_size(offsets, extent, target)
    keep = _representatives(points, _voxel_keys(offsets, extent, size))
    rng = np.random.default_rng(seed)
    if len(keep) >= target:
        return keep[np.sort(rng.choice(len(keep), size=target, replace=False))]
    # Rare (extremely clustered input): fill up with other points, chosen at random.
    rest = np.setdiff1d(np.arange(len(points)), keep)
    extra = rest[rng.choice(len(rest), size=target - len(keep), replace=False)]
    return np.concatenate([keep, np.sort(extra)])
