"""Partial views of a shape, and weights that discount the open rim of a partial surface.

A scan sees only the side of a part that faced the sensor. Two measures make a partial query
match its whole catalogue model better (``core.evaluation.scan_retrieval`` measures both):

- ``virtual_views``: what a few fixed, spread viewpoints see of a model (hidden point
  removal, ``hidden_point_removal``); each view is described and indexed as an extra entry
  of the same model, so a partial scan can meet a partial view;
- ``frame_directions``: view directions fixed in a shape's own (signed principal) frame,
  for the evaluation (measured as scan mode's views and declined);
- ``boundary_weights``: points near the open boundary of a partial surface carry the
  Laplacian's free-boundary artefacts; their share of the descriptor's histograms is faded
  out. On a closed surface no point is on a rim and every weight is 1.

Used by ``core.pipeline`` (the service) and ``core.evaluation`` (the measurements) alike.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError, cKDTree

from core.extrinsic import neighbourhood_normals

__all__ = [
    "boundary_weights", "frame_directions", "hidden_point_removal", "signed_principal_axes",
    "view_directions", "view_from", "virtual_view", "virtual_views",
]


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
        Larger sees more (and lets hidden points through). On a densely sampled sphere 2-3.5
        matches the true visible cap.

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


def view_directions(count: int) -> np.ndarray:
    """``count`` near-uniform unit directions ``(count, 3)`` (Fibonacci spiral), fixed."""
    index = np.arange(count) + 0.5
    z = 1.0 - 2.0 * index / count
    angle = np.pi * (1.0 + 5.0**0.5) * index
    ring = np.sqrt(1.0 - z**2)
    return np.column_stack([ring * np.cos(angle), ring * np.sin(angle), z])


def signed_principal_axes(points: np.ndarray) -> np.ndarray:
    """The principal axes of ``points``, largest spread first, each signed so that the
    points' third moment along it is not negative.

    The sign makes the frame the same for shapes of one kind: each axis points along the
    longer tail of the points' spread (a screw's long axis from its head to its tip,
    whichever way it was uploaded); a symmetric shape looks the same either way.

    Parameters
    ----------
    points : (n, 3) float

    Returns
    -------
    axes : (3, 3) float
        Unit axes as columns.
    """
    offsets = points - points.mean(axis=0)
    variances, axes = np.linalg.eigh(offsets.T @ offsets)
    axes = axes[:, np.argsort(variances)[::-1]]
    third = ((offsets @ axes) ** 3).sum(axis=0)
    return axes * np.where(third < 0.0, -1.0, 1.0)


def frame_directions(points: np.ndarray, tilt: float) -> np.ndarray:
    """Three orthogonal view directions ``(3, 3)`` (rows) fixed in the shape's own frame.

    The signed principal axes (``signed_principal_axes``) turned by ``tilt`` radians about
    their diagonal ``(1, 1, 1)``: direction ``k`` still leans towards axis ``k`` (an end
    view, a side view, a top view) but lies in no principal plane, so that a flat part is
    never seen exactly edge-on. Measured as scan mode's views and declined: the
    evaluation's scan kind ``fview``.

    Parameters
    ----------
    points : (n, 3) float
    tilt : float
        Radians.

    Returns
    -------
    directions : (3, 3) float
        Unit rows, orthogonal; they turn with ``points``.
    """
    diagonal = np.ones(3) / np.sqrt(3.0)
    cross = np.array([[0.0, -diagonal[2], diagonal[1]], [diagonal[2], 0.0, -diagonal[0]],
                      [-diagonal[1], diagonal[0], 0.0]])
    # Rodrigues' rotation about the diagonal.
    turn = (np.cos(tilt) * np.eye(3) + np.sin(tilt) * cross
            + (1.0 - np.cos(tilt)) * np.outer(diagonal, diagonal))
    return (signed_principal_axes(points) @ turn).T


def virtual_views(
    points: np.ndarray, count: int, distance: float = 3.0, exponent: float = 3.0
) -> list[np.ndarray]:
    """What each of ``count`` fixed directions (``view_directions``) sees of ``points``.

    Clean partial views (no noise, no outliers): the viewpoints lie ``distance`` bounding-box
    diagonals from the box centre.

    Parameters
    ----------
    points : (n, 3) float
    count : int
    distance : float
    exponent : float
        Hidden point removal's ``gamma`` (``hidden_point_removal``).

    Returns
    -------
    views : list of (m_i, 3) float
        One per direction, in the order of ``view_directions(count)``; rows of ``points``.
        Empty when the view is degenerate: a flat shape seen exactly edge-on.
    """
    return [virtual_view(points, index, count, distance, exponent) for index in range(count)]


def virtual_view(
    points: np.ndarray, index: int, count: int, distance: float = 3.0, exponent: float = 3.0
) -> np.ndarray:
    """View ``index`` of ``virtual_views(points, count, distance, exponent)``.

    Returns
    -------
    view : (m, 3) float
        Rows of ``points``; empty when a flat shape is seen exactly edge-on.
    """
    return view_from(points, view_directions(count)[index], distance, exponent)


def view_from(
    points: np.ndarray, direction: np.ndarray, distance: float = 3.0, exponent: float = 3.0
) -> np.ndarray:
    """What a viewpoint ``distance`` bounding-box diagonals from the box centre along the
    unit ``direction : (3,) float`` sees of ``points : (n, 3) float`` (rows; empty when a
    flat shape is seen exactly edge-on)."""
    low, high = points.min(axis=0), points.max(axis=0)
    centre, diagonal = (low + high) / 2.0, float(np.linalg.norm(high - low))
    viewpoint = centre + distance * diagonal * direction
    try:
        seen = hidden_point_removal(points, viewpoint, exponent)
    except QhullError:  # the points and the viewpoint lie in one plane: no surface seen
        seen = np.empty(0, dtype=int)
    return points[seen]


def boundary_weights(
    points: np.ndarray, neighbours: int = 16, threshold: float = 0.35, reach: float = 0.1
) -> np.ndarray:
    """Histogram weights ``(n,)`` in [0, 1] that fade out towards an open boundary.

    A point is on the boundary when the centroid of its ``neighbours`` nearest points, projected
    on the local tangent plane (PCA), is off by more than ``threshold`` mean neighbour
    distances: inside a surface the neighbours surround the point, on a rim they lie to one
    side. The weight grows linearly with the distance to the nearest boundary point and
    reaches 1 at ``reach`` times the square root of the surface area (estimated from the
    point spacing): about the diffusion length of the descriptor's mid times on a unit-area
    shape.

    Parameters
    ----------
    points : (n, 3) float
    neighbours : int
    threshold : float
    reach : float

    Returns
    -------
    weights : (n,) float
        All ones when no point is on a boundary (a closed surface).
    """
    distances, index = cKDTree(points).query(points, k=neighbours + 1)
    normal = neighbourhood_normals(points, index[:, 1:])
    offset = (points[index[:, 1:]] - points[:, None, :]).mean(axis=1)
    tangential = offset - np.sum(offset * normal, axis=1, keepdims=True) * normal
    spacing = distances[:, 1:].mean(axis=1)
    on_rim = np.linalg.norm(tangential, axis=1) > threshold * spacing
    if not on_rim.any():
        return np.ones(len(points))
    # n points at spacing s cover an area of about n s^2.
    scale = reach * np.sqrt(len(points)) * float(np.median(distances[:, 1]))
    to_rim, _ = cKDTree(points[on_rim]).query(points)
    return np.clip(to_rim / scale, 0.0, 1.0)
