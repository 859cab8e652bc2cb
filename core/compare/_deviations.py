"""How far two aligned parts are apart, point by point, in their units.

Each point of one part gets its distance to the other part's surface as sampled, both ways:

* ``"point"``: to the nearest sample point of the other part;
* ``"surface"`` (the default): the same nearest points, each taken as the small disc of
  surface it stands for (in its tangent plane, from a PCA of its neighbours, with the radius
  of its ``DISC_NEIGHBOURS``-th neighbour), the least distance to the ``CANDIDATES`` nearest
  such discs. Never more than ``"point"``'s.

Why the discs: two samplings of one surface are apart by about their spacing even where
the surfaces coincide. Between 3000 random points of a 20 mm cube and another 3000 of the
same cube the nearest-point RMS is 1.46 % of the diagonal and 38 % of the points lie within
1 % of it; to the discs it is 0.14 % and all but 0.2 % lie within 1 % (0.1-0.3 % on the
tests' other parts, re-sampled and aligned, where nearest points give 0.9-1.5 %;
``tests/core/test_align.py``): what is left is how far the surfaces are, not the sampling.
Where a point lies beyond the other part's edge (a stretched end, the unseen side of a
scan), the disc's edge is only its radius past the nearest point, so the distance there is
still the gap.

Figures per direction: RMS, mean, 95th percentile and maximum, and the share of points
within a tolerance; and the extents of both parts along the first part's principal axes,
whose ratios say how much larger the second is along each.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.spatial import cKDTree

__all__ = [
    "CANDIDATES",
    "DISC_NEIGHBOURS",
    "Deviations",
    "Direction",
    "Metric",
    "Surface",
    "deviations",
    "principal_axes",
    "principal_extents",
    "surface_distances",
]

Metric = Literal["surface", "point"]

#: A sample point's disc reaches as far as its this-many-th nearest neighbour.
DISC_NEIGHBOURS = 6
#: Neighbours of a point whose plane is its disc's (its own included).
NORMAL_NEIGHBOURS = 10
#: Nearest discs whose least distance is a point's.
CANDIDATES = 4
#: Extents are measured between these quantiles along each axis (a stray point of a scan
#: does not make it longer), as ``core.size`` measures a cloud.
EXTENT_QUANTILES = (0.002, 0.998)


@dataclass(frozen=True)
class Surface:
    """A sampled surface ready for distance queries.

    Attributes
    ----------
    points : (n, 3) float
    normals : (n, 3) float
        Unit normals of each point's disc (sign arbitrary).
    radii : (n,) float
        Each disc's radius.
    tree : scipy.spatial.cKDTree
        Of ``points``.
    """

    points: np.ndarray
    normals: np.ndarray
    radii: np.ndarray
    tree: cKDTree

    @classmethod
    def of(cls, points: np.ndarray) -> Surface:
        """The discs of ``points : (n, 3) float`` (n >= 2)."""
        points = np.asarray(points, dtype=np.float64)
        tree = cKDTree(points)
        k = min(max(NORMAL_NEIGHBOURS, DISC_NEIGHBOURS + 1), len(points))
        distances, index = tree.query(points, k=k)
        local = points[index[:, :NORMAL_NEIGHBOURS]]
        centred = local - local.mean(axis=1, keepdims=True)
        _, axes = np.linalg.eigh(np.einsum("nki,nkj->nij", centred, centred))
        radii = distances[:, min(DISC_NEIGHBOURS, k - 1)]
        return cls(points=points, normals=axes[:, :, 0], radii=radii, tree=tree)


def surface_distances(
    points: np.ndarray, surface: Surface, metric: Metric = "surface"
) -> np.ndarray:
    """The distance of each of ``points : (m, 3) float`` from ``surface``, ``(m,) float``
    (see the module's docstring for ``metric``)."""
    points = np.asarray(points, dtype=np.float64)
    if metric == "point":
        nearest, _ = surface.tree.query(points)
        return np.asarray(nearest, dtype=np.float64)
    k = min(CANDIDATES, len(surface.points))
    _, index = surface.tree.query(points, k=k)
    index = index.reshape(len(points), k)
    offsets = points[:, None, :] - surface.points[index]
    normals = surface.normals[index]
    height = np.einsum("mki,mki->mk", offsets, normals)
    across = np.sqrt(np.maximum(np.einsum("mki,mki->mk", offsets, offsets) - height**2, 0.0))
    beyond = np.maximum(across - surface.radii[index], 0.0)
    return np.asarray(np.sqrt(height**2 + beyond**2).min(axis=1))


@dataclass(frozen=True)
class Direction:
    """The distances of one part's points from the other part, and their figures.

    Attributes
    ----------
    distances : (n,) float
        Per point, in the units of the parts.
    rms, mean, p95, max : float
    within : float
        Share of the points within the tolerance, in [0, 1].
    """

    distances: np.ndarray
    rms: float
    mean: float
    p95: float
    max: float
    within: float

    @classmethod
    def of(cls, distances: np.ndarray, tolerance: float) -> Direction:
        d = np.asarray(distances, dtype=np.float64)
        return cls(
            distances=d,
            rms=float(np.sqrt(np.mean(d**2))),
            mean=float(d.mean()),
            p95=float(np.quantile(d, 0.95)),
            max=float(d.max()),
            within=float(np.mean(d <= tolerance)),
        )


@dataclass(frozen=True)
class Deviations:
    """How far two aligned parts ``a`` and ``b`` are apart.

    Attributes
    ----------
    a_to_b : Direction
        Each point of ``a`` from ``b``.
    b_to_a : Direction
        Each point of ``b`` from ``a``.
    tolerance : float
    metric : str
        ``"surface"`` or ``"point"``.
    axes : (3, 3) float
        ``a``'s principal axes as columns, largest spread first.
    extents_a, extents_b : (3,) float
        Extents of ``a`` and ``b`` along ``axes``.
    """

    a_to_b: Direction
    b_to_a: Direction
    tolerance: float
    metric: str
    axes: np.ndarray
    extents_a: np.ndarray
    extents_b: np.ndarray

    @property
    def size_ratios(self) -> np.ndarray:
        """``(3,) float``: ``b``'s extents over ``a``'s along ``a``'s principal axes."""
        return self.extents_b / np.maximum(self.extents_a, 1e-300)


def principal_extents(points: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """Extents ``(3,)`` of ``points : (n, 3)`` along the unit columns of ``axes : (3, 3)``
    (between the ``EXTENT_QUANTILES``)."""
    coordinates = np.asarray(points, dtype=np.float64) @ axes
    low, high = np.quantile(coordinates, EXTENT_QUANTILES, axis=0)
    return np.asarray(high - low)


def principal_axes(points: np.ndarray) -> np.ndarray:
    """The principal axes of ``points : (n, 3)`` as columns ``(3, 3)``, largest spread
    first."""
    offsets = points - points.mean(axis=0)
    variances, axes = np.linalg.eigh(offsets.T @ offsets)
    return np.asarray(axes[:, np.argsort(variances)[::-1]])


def deviations(
    a: np.ndarray,
    b_aligned: np.ndarray,
    tolerance: float,
    *,
    metric: Metric = "surface",
    surfaces: tuple[Surface, Surface] | None = None,
) -> Deviations:
    """The deviations of two aligned parts.

    Parameters
    ----------
    a : (n, 3) float
        The reference part.
    b_aligned : (m, 3) float
        The other part, in ``a``'s frame (``Alignment.apply``).
    tolerance : float
        Distance (``a``'s units) within which a point counts as matched; > 0.
    metric : {"surface", "point"}
        See the module's docstring.
    surfaces : (Surface, Surface), optional
        ``Surface.of(a)`` and ``Surface.of(b_aligned)`` when already built.

    Returns
    -------
    Deviations
    """
    if not tolerance > 0:
        raise ValueError(f"tolerance must be positive, not {tolerance}")
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b_aligned, dtype=np.float64)
    surface_a, surface_b = surfaces or (Surface.of(a), Surface.of(b))
    axes = principal_axes(a)
    return Deviations(
        a_to_b=Direction.of(surface_distances(a, surface_b, metric), tolerance),
        b_to_a=Direction.of(surface_distances(b, surface_a, metric), tolerance),
        tolerance=float(tolerance),
        metric=metric,
        axes=axes,
        extents_a=principal_extents(a, axes),
        extents_b=principal_extents(b, axes),
    )
