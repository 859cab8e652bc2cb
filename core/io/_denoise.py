"""Denoising scanned point clouds by projection onto local surface fits.

Range noise scatters scan points off the surface along its normal. The robust Laplacian
triangulates each point's neighbourhood, so that scatter becomes small-scale roughness: the
short-wavelength eigenpairs, which the WKS and the short HKS times read, then describe the
noise rather than the shape. Projecting each point onto a surface fitted to its neighbours
removes most of the normal scatter and leaves the tangential positions (the sampling) alone.

Two fits, both in the local principal frame of a point's ``neighbours`` nearest points
(itself included):

* ``"plane"``: the PCA plane through their centroid. Each projection averages the normal
  offsets of ``k`` points, so the noise shrinks by about ``sqrt(k)``; a curved surface is
  pulled inwards by about ``r^2 / (4 R)`` (neighbourhood radius ``r``, curvature radius
  ``R``), small against the noise for the densities the engine uses.
* ``"quadric"``: a least-squares height field ``h(u, v)`` of degree 2 over that plane; no
  curvature bias, more variance (six coefficients from ``k`` points).

The number of points and their order are preserved; the result depends only on the input
(no randomness).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["DENOISE_FITS", "denoise_points"]

DENOISE_FITS: tuple[str, ...] = ("plane", "quadric")
# Points per block of the batched fits: bounds the (block, k, 3) temporaries.
_BLOCK = 4096


def _local_frames(local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centroids ``(b, 3)`` and principal axes ``(b, 3, 3)`` (columns, normal first)."""
    centroid = local.mean(axis=1)
    centred = local - centroid[:, None, :]
    _, axes = np.linalg.eigh(np.einsum("bki,bkj->bij", centred, centred))
    return centroid, axes  # eigh sorts ascending: column 0 is the normal


def _project_plane(points: np.ndarray, local: np.ndarray) -> np.ndarray:
    centroid, axes = _local_frames(local)
    normal = axes[:, :, 0]
    offset = np.sum((points - centroid) * normal, axis=1, keepdims=True)
    return points - offset * normal


def _project_quadric(points: np.ndarray, local: np.ndarray) -> np.ndarray:
    centroid, axes = _local_frames(local)
    # Coordinates in the local frame, centred on the point itself: the fit is then evaluated
    # at (0, 0) and only the height changes.
    frame = np.einsum("bki,bij->bkj", local - points[:, None, :], axes)
    h, u, v = frame[..., 0], frame[..., 1], frame[..., 2]
    design = np.stack([np.ones_like(u), u, v, u * u, u * v, v * v], axis=-1)  # (b, k, 6)
    gram = np.einsum("bki,bkj->bij", design, design)
    # A tiny ridge keeps the solve defined when the neighbours are (nearly) collinear.
    scale = np.trace(gram, axis1=1, axis2=2)[:, None, None] / 6.0
    gram = gram + 1e-9 * scale * np.eye(6)
    coefficients = np.linalg.solve(gram, np.einsum("bki,bk->bi", design, h)[..., None])[..., 0]
    height = coefficients[:, 0]
    # A near-degenerate fit can fling a point far away; never move it further than the plane
    # projection would (its offset from the centroid along the normal) plus that same amount.
    plane_offset = np.abs(np.sum((centroid - points) * axes[:, :, 0], axis=1))
    height = np.clip(height, -2.0 * plane_offset, 2.0 * plane_offset)
    return points + height[:, None] * axes[:, :, 0]


def denoise_points(
    points: np.ndarray, neighbours: int = 16, passes: int = 1, fit: str = "plane"
) -> np.ndarray:
    """Move every point onto a surface fitted to its nearest neighbours.

    Parameters
    ----------
    points : (n, 3) float
    neighbours : int
        Points per local fit, the point itself included (at least 6 for ``"quadric"``).
    passes : int
        Repeated projections, each with fresh neighbours; 0 returns a copy.
    fit : str
        ``"plane"`` or ``"quadric"`` (see the module docstring).

    Returns
    -------
    (n, 3) float64
        Same count and order as ``points``.
    """
    if fit not in DENOISE_FITS:
        raise ValueError(f"denoise fit must be one of {DENOISE_FITS}, not {fit!r}")
    if neighbours < (6 if fit == "quadric" else 3) or passes < 0:
        raise ValueError("denoise needs enough neighbours for its fit and passes >= 0")
    result = np.array(points, dtype=np.float64, copy=True)
    k = min(neighbours, len(result))
    if k < (6 if fit == "quadric" else 3):
        return result
    project = _project_quadric if fit == "quadric" else _project_plane
    for _ in range(passes):
        _, index = cKDTree(result).query(result, k=k)
        moved = np.empty_like(result)
        for start in range(0, len(result), _BLOCK):
            block = slice(start, start + _BLOCK)
            moved[block] = project(result[block], result[index[block]])
        result = moved
    return result
