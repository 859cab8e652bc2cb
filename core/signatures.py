"""Per-point spectral signatures from eigenpairs.

- Heat Kernel Signature (Sun, Ovsjanikov & Guibas 2009):
  ``HKS(x, t) = sum_i exp(-lambda_i t) phi_i(x)^2``, heat that stays at x after time t.
  The scaled variant divides by the heat trace ``sum_i exp(-lambda_i t)``; with
  M-orthonormal eigenvectors and unit total area its area-weighted mean is exactly 1.
- Wave Kernel Signature (Aubry, Schlickewei & Cremers 2011), from the published formula:
  ``WKS(x, e) = sum_i phi_i(x)^2 exp(-(e - log lambda_i)^2 / 2 sigma^2) / C_e``.

Time and energy grids are arguments, never derived from one model's spectrum: a database
shares one grid so that signatures of different models are comparable.
"""

from __future__ import annotations

import numpy as np

__all__ = ["heat_kernel_signature", "wave_kernel_signature", "zero_eigenvalue_count"]


def heat_kernel_signature(
    eigenvalues: np.ndarray,
    eigenvectors: np.ndarray,
    times: np.ndarray,
    *,
    scaled: bool = False,
) -> np.ndarray:
    """Heat Kernel Signature of every point at every time.

    Parameters
    ----------
    eigenvalues : (k,) float
    eigenvectors : (n, k) float
        M-orthonormal.
    times : (s,) float
    scaled : bool
        Divide by the heat trace at each time.

    Returns
    -------
    hks : (n, s) float
    """
    # Clip tiny negative round-off of the zero eigenvalue: exp(+eps) would exceed 1.
    decay = np.exp(-np.outer(np.maximum(eigenvalues, 0.0), times))  # (k, s)
    hks = (eigenvectors**2) @ decay
    if scaled:
        hks /= decay.sum(axis=0)
    return hks


def zero_eigenvalue_count(eigenvalues: np.ndarray, tolerance: float = 1e-6) -> int:
    """Number of (numerically) zero eigenvalues: one per connected component.

    ``tolerance`` is relative to the largest eigenvalue given.
    """
    scale = float(np.max(np.abs(eigenvalues))) if eigenvalues.size else 0.0
    return int(np.count_nonzero(eigenvalues <= tolerance * max(scale, 1.0)))


def wave_kernel_signature(
    eigenvalues: np.ndarray,
    eigenvectors: np.ndarray,
    energies: np.ndarray,
    sigma: float,
) -> np.ndarray:
    """Wave Kernel Signature of every point at every log-energy.

    Parameters
    ----------
    eigenvalues : (k,) float
    eigenvectors : (n, k) float
    energies : (e,) float
        Log-energies ``e``.
    sigma : float
        Width of the log-normal energy filters.

    Returns
    -------
    wks : (n, e) float
        Zero eigenvalues (constant modes) are left out, as in the published definition.
    """
    keep = slice(zero_eigenvalue_count(eigenvalues), None)
    log_eigenvalues = np.log(eigenvalues[keep])
    filters = np.exp(-((energies[None, :] - log_eigenvalues[:, None]) ** 2) / (2 * sigma**2))
    normaliser = filters.sum(axis=0)
    # An energy far outside the computed spectrum has no support; keep it at zero, not NaN.
    normaliser[normaliser <= 0] = 1.0
    return (eigenvectors[:, keep] ** 2) @ filters / normaliser
