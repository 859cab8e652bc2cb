"""Normalisation: translation and scale out of the way before the spectrum is taken.

The cutoff criterion compares ``exp(-t * lambda)`` against an absolute threshold, so the
eigenvalues of every model must live on one scale. Two conventions:

- unit surface area (default): by Weyl's law ``lambda_n ~ 4 pi n / area``, so after it the
  n-th eigenvalue of every surface is close to ``4 pi n`` whatever its shape;
- unit bounding-box diagonal, as in Williams & Ilies.

Both Laplacians give a stiffness matrix that does not change when the points are scaled by
``c`` and a mass matrix that scales by ``c**2``. Unit area therefore needs no second
Laplacian: dividing the mass matrix by its trace is the same as rescaling the points first.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["centre", "unit_area_mass", "unit_bbox_scale"]


def centre(points: np.ndarray) -> np.ndarray:
    """Move the bounding-box centre to the origin.

    Parameters
    ----------
    points : (n, 3) float

    Returns
    -------
    centred : (n, 3) float
    """
    # The bounding-box centre, not the mean, so that uneven sampling density does not move it.
    low, high = points.min(axis=0), points.max(axis=0)
    return points - (low + high) / 2.0


def unit_bbox_scale(points: np.ndarray) -> float:
    """Factor that makes the bounding-box diagonal of ``points : (n, 3) float`` equal to 1."""
    diagonal = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    if diagonal <= 0.0:
        raise ValueError("points have zero extent")
    return 1.0 / diagonal


def unit_area_mass(
    points: np.ndarray, mass: sp.spmatrix
) -> tuple[np.ndarray, sp.csr_matrix]:
    """Rescale ``points`` and the mass matrix to unit total surface area.

    Parameters
    ----------
    points : (n, 3) float
    mass : (n, n) sparse diagonal
        Area each point stands for; its trace is the surface area.

    Returns
    -------
    points : (n, 3) float
        Scaled by ``1 / sqrt(area)``.
    mass : (n, n) sparse diagonal
        Divided by ``area`` (trace 1). The stiffness matrix is scale invariant and unchanged.
    """
    area = float(mass.diagonal().sum())
    if not np.isfinite(area) or area <= 0.0:
        raise ValueError("mass matrix has no positive area")
    return points / np.sqrt(area), sp.csr_matrix(mass / area)
