"""Analytic test shapes with known Laplace-Beltrami spectra, shared by the test modules.

``sphere_points``, ``fibonacci_sphere_points``
    Unit sphere (random uniform, or the near-uniform Fibonacci spiral), eigenvalues l(l + 1)
    with multiplicity 2l + 1: 0; 2 x3; 6 x5; 12 x7; 20 x9.
``plate_points``
    Thin rectangular plate a x b. Sampled only on its top face it is a flat rectangle with
    free (Neumann) boundary, eigenvalues pi^2 (m^2 / a^2 + n^2 / b^2).
``torus_points``
    Torus of revolution (radii R > r); no closed-form spectrum, used for numerical checks.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "SPHERE_EIGENVALUES",
    "fibonacci_sphere_points",
    "plate_eigenvalues",
    "plate_points",
    "sphere_eigenvalues",
    "sphere_points",
    "torus_points",
]


def sphere_eigenvalues(count: int) -> np.ndarray:
    """The first ``count`` eigenvalues of the unit sphere, l(l + 1) repeated 2l + 1 times.

    Returns
    -------
    (count,) float
    """
    degrees = np.repeat(np.arange(count), 2 * np.arange(count) + 1)[:count]
    return (degrees * (degrees + 1)).astype(float)


SPHERE_EIGENVALUES = sphere_eigenvalues(16)


def sphere_points(n: int, seed: int = 0) -> np.ndarray:
    """Uniform random samples of the unit sphere (normalised Gaussians).

    Returns
    -------
    (n, 3) float
    """
    gaussian = np.random.default_rng(seed).normal(size=(n, 3))
    return gaussian / np.linalg.norm(gaussian, axis=1, keepdims=True)


def fibonacci_sphere_points(n: int) -> np.ndarray:
    """Near-uniform deterministic samples of the unit sphere (Fibonacci spiral).

    Returns
    -------
    (n, 3) float
    """
    index = np.arange(n) + 0.5
    height = 1.0 - 2.0 * index / n
    angle = np.pi * (1.0 + np.sqrt(5.0)) * index
    ring = np.sqrt(1.0 - height**2)
    return np.column_stack([ring * np.cos(angle), ring * np.sin(angle), height])


def plate_points(n: int, a: float = 1.0, b: float = 1.0, seed: int = 0) -> np.ndarray:
    """Uniform random samples of the rectangle [0, a] x [0, b] in the plane z = 0.

    Returns
    -------
    (n, 3) float
    """
    uniform = np.random.default_rng(seed).random((n, 2)) * np.array([a, b])
    return np.column_stack([uniform, np.zeros(n)])


def plate_eigenvalues(count: int, a: float = 1.0, b: float = 1.0) -> np.ndarray:
    """The first ``count`` Neumann eigenvalues pi^2 (m^2/a^2 + n^2/b^2) of an a x b rectangle.

    Returns
    -------
    (count,) float
    """
    modes = np.arange(count + 1)
    values = np.pi**2 * (modes[:, None] ** 2 / a**2 + modes[None, :] ** 2 / b**2)
    return np.sort(values.ravel())[:count]


def torus_points(n: int, R: float = 1.0, r: float = 0.4, seed: int = 0) -> np.ndarray:  # noqa: N803
    """Area-uniform random samples of a torus of revolution (rejection on the area element).

    Parameters
    ----------
    n : int
        Number of samples.
    R, r : float
        Distance from the axis to the tube centre, tube radius (R > r).

    Returns
    -------
    (n, 3) float
    """
    rng = np.random.default_rng(seed)
    accepted: list[np.ndarray] = []
    total = 0
    while total < n:
        around, tube = rng.random((2, 2 * n)) * 2 * np.pi
        # The area element is proportional to R + r cos(tube): accept with that probability.
        keep = rng.random(2 * n) * (R + r) < R + r * np.cos(tube)
        around, tube = around[keep], tube[keep]
        ring = R + r * np.cos(tube)
        accepted.append(
            np.column_stack([ring * np.cos(around), ring * np.sin(around), r * np.sin(tube)])
        )
        total += len(around)
    return np.concatenate(accepted)[:n]
