"""Statistical outlier removal for scanned point clouds.

Depth sensors add stray points off the surface. The robust Laplacian gives such an isolated
point a huge area (measured on simulated capod scans: up to 110 times the median area, against
6-8 times on clean samples), which distorts the mass matrix, the unit-area scaling and every
area-weighted histogram; on simulated three-view scans it made retrieval no better than
chance (docs/results.md). The classic filter of scan pipelines removes them: a point stays
when its mean distance to its nearest neighbours is below the mean of that quantity plus
``z`` standard deviations.

It runs before thinning on purpose: even thinning keeps one point per occupied voxel, so it
would keep every isolated outlier and raise their share.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["spacing_inliers", "statistical_inliers"]


def statistical_inliers(points: np.ndarray, neighbours: int = 8, z: float = 2.0) -> np.ndarray:
    """Mask of the points that are not statistical outliers.

    Parameters
    ----------
    points : (n, 3) float
    neighbours : int
        Neighbours whose mean distance measures how isolated a point is.
    z : float
        Points with a mean distance above ``mean + z * std`` (over all points) are outliers.

    Returns
    -------
    inliers : (n,) bool
    """
    if len(points) <= neighbours:
        return np.ones(len(points), dtype=bool)
    distances, _ = cKDTree(points).query(points, neighbours + 1)
    spacing = distances[:, 1:].mean(axis=1)  # column 0 is the point itself
    return spacing <= spacing.mean() + z * spacing.std()


def spacing_inliers(points: np.ndarray, neighbours: int = 8, ratio: float = 2.0) -> np.ndarray:
    """Mask of the points whose mean neighbour distance is at most ``ratio`` times the median.

    The median, unlike the mean and standard deviation of ``statistical_inliers``, does not
    move with the outliers themselves, so the cut stays at the same spacing whether a cloud
    has no stray points (a clean sample keeps nearly all its points) or many.

    Parameters
    ----------
    points : (n, 3) float
    neighbours : int
    ratio : float
        Points with a mean distance above ``ratio * median`` are outliers.

    Returns
    -------
    inliers : (n,) bool
    """
    if len(points) <= neighbours:
        return np.ones(len(points), dtype=bool)
    distances, _ = cKDTree(points).query(points, neighbours + 1)
    spacing = distances[:, 1:].mean(axis=1)
    return spacing <= ratio * float(np.median(spacing))
