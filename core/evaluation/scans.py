"""Simulated 3D scans of a sampled model: what a depth sensor would see of it.

A scan sees only the side of the object facing the sensor, adds range noise and picks up a
few stray points. From a dense point sample of a clean model we make:

- a single-view scan: points visible from one random viewpoint, found by hidden point removal
  (Katz, Tal & Basri 2007: spherical flipping about the viewpoint, then the convex hull of the
  flipped points and the viewpoint; points on the hull are visible);
- a multi-view scan: the union of what three random viewpoints see.

Then isotropic Gaussian noise with standard deviation ``noise`` times the bounding-box diagonal
of the model, and uniform outlier points in the model's (slightly enlarged) bounding box, as
many as make up a share ``outliers`` of the result.
Everything is drawn from one ``numpy.random.Generator``, so a seed fixes the scan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull

__all__ = [
    "ScanSettings",
    "add_noise_and_outliers",
    "hidden_point_removal",
    "multi_view_scan",
    "random_rotation",
    "random_viewpoint",
    "simulate_scan",
    "single_view_scan",
]


@dataclass(frozen=True)
class ScanSettings:
    """Parameters of the scan simulator.

    Attributes
    ----------
    noise : float
        Standard deviation of the Gaussian noise, as a fraction of the bbox diagonal.
    outliers : float
        Share of outlier points in the final scan.
    views : int
        Viewpoints merged by the multi-view scan.
    distance : float
        Distance of the viewpoint from the bbox centre, in bbox diagonals.
    hpr_exponent : float
        Katz et al.'s ``gamma``: the flipping radius is ``10**gamma`` times the farthest point.
        Larger sees more (and lets hidden points through). On a densely sampled sphere 2-3.5
        matches the true visible cap; on concave models (a human figure) 3 keeps about 30 %
        of the points from 3 diagonals away; 5 lets through half of the far side.
    """

    noise: float = 0.005
    outliers: float = 0.01
    views: int = 3
    distance: float = 3.0
    hpr_exponent: float = 3.0


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A rotation drawn uniformly from SO(3), ``(3, 3)``.

    QR of a Gaussian matrix with the signs of R's diagonal moved into Q gives a Haar-uniform
    orthogonal matrix (Mezzadri 2007); a reflection is turned into a rotation.
    """
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def _bbox(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    low, high = points.min(axis=0), points.max(axis=0)
    return low, high, float(np.linalg.norm(high - low))


def random_viewpoint(points: np.ndarray, rng: np.random.Generator, distance: float) -> np.ndarray:
    """A viewpoint ``(3,)`` in a uniformly random direction, ``distance`` diagonals away."""
    low, high, diagonal = _bbox(points)
    direction = rng.standard_normal(3)
    direction /= np.linalg.norm(direction)
    return (low + high) / 2.0 + distance * diagonal * direction


def hidden_point_removal(
    points: np.ndarray, viewpoint: np.ndarray, exponent: float = 3.0
) -> np.ndarray:
    """Indices of the points visible from ``viewpoint`` (Katz, Tal & Basri 2007).

    Parameters
    ----------
    points : (n, 3) float
    viewpoint : (3,) float
    exponent : float
        ``gamma``; the flipping sphere's radius is ``10**gamma * max |p - viewpoint|``.

    Returns
    -------
    visible : (v,) int
        Sorted indices into ``points``.
    """
    relative = points - viewpoint
    norms = np.maximum(np.linalg.norm(relative, axis=1, keepdims=True), 1e-300)
    radius = norms.max() * 10.0**exponent
    # Spherical flipping: near points go far out along their ray, so the ones in front of the
    # surface (seen from the viewpoint) end up on the convex hull.
    flipped = relative + 2.0 * (radius - norms) * relative / norms
    hull = ConvexHull(np.vstack([flipped, np.zeros((1, 3))]))
    visible = hull.vertices[hull.vertices < len(points)]
    return np.sort(visible)


def add_noise_and_outliers(
    points: np.ndarray,
    rng: np.random.Generator,
    diagonal: float,
    box: tuple[np.ndarray, np.ndarray],
    noise: float,
    outliers: float,
) -> np.ndarray:
    """Gaussian noise on every point, then uniform outliers in the enlarged box.

    Parameters
    ----------
    points : (n, 3) float
    diagonal : float
        Bounding-box diagonal of the clean model: the unit of ``noise``.
    box : (low, high), each (3,) float
        Bounding box of the clean model; outliers fall in it, enlarged by 10 % per side.
    noise, outliers : float
        See ``ScanSettings``.

    Returns
    -------
    scan : (n + o, 3) float
        ``o = round(n * outliers / (1 - outliers))`` so outliers are that share of the result;
        outliers are appended last.
    """
    noisy = points + rng.normal(scale=noise * diagonal, size=points.shape)
    count = int(round(len(points) * outliers / (1.0 - outliers)))
    low, high = box
    pad = 0.1 * (high - low)
    stray = rng.uniform(low - pad, high + pad, size=(count, 3))
    return np.vstack([noisy, stray])


def single_view_scan(
    points: np.ndarray, rng: np.random.Generator, settings: ScanSettings = ScanSettings()
) -> np.ndarray:
    """What one random viewpoint sees of ``points : (n, 3)``, with noise and outliers."""
    return simulate_scan(points, rng, settings, views=1)


def multi_view_scan(
    points: np.ndarray, rng: np.random.Generator, settings: ScanSettings = ScanSettings()
) -> np.ndarray:
    """The union of what ``settings.views`` random viewpoints see, with noise and outliers."""
    return simulate_scan(points, rng, settings, views=settings.views)


def simulate_scan(
    points: np.ndarray,
    rng: np.random.Generator,
    settings: ScanSettings = ScanSettings(),
    views: int = 1,
) -> np.ndarray:
    """Scan ``points : (n, 3) float`` from ``views`` random viewpoints.

    Returns
    -------
    scan : (m, 3) float
        Visible points (each at most once, even if several views see it) with noise, then
        the outliers.
    """
    low, high, diagonal = _bbox(points)
    seen = np.zeros(len(points), dtype=bool)
    for _ in range(views):
        viewpoint = random_viewpoint(points, rng, settings.distance)
        seen[hidden_point_removal(points, viewpoint, settings.hpr_exponent)] = True
    return add_noise_and_outliers(
        points[seen], rng, diagonal, (low, high), settings.noise, settings.outliers
    )
