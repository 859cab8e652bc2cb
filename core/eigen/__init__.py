"""Smallest eigenpairs of the Laplace-Beltrami estimate, L phi = lambda M phi.

``SpectralSolver``
    Banded shift-invert Lanczos (Vallet & Levy 2008) with one cached factorisation per shift,
    inertia-checked bands, and incremental ``solve(count)`` calls that never recompute.
``smallest_eigenpairs``
    One big shift-invert Lanczos call: the reference used by the tests and the benchmark.
``pin_blas_threads``
    Context manager limiting BLAS threads (oversubscription made solves 8x slower).
"""

from __future__ import annotations

from core.eigen._solver import BandRecord, SpectralSolver, default_shift, smallest_eigenpairs
from core.eigen._threads import pin_blas_threads

__all__ = [
    "BandRecord",
    "SpectralSolver",
    "default_shift",
    "pin_blas_threads",
    "smallest_eigenpairs",
]
