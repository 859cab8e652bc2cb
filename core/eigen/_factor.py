"""One sparse factorisation of K = L - s M per shift s, used twice.

QDLDL (the sparse LDL^T of the OSQP project) computes K = P^T L D L^T P with an AMD
fill-reducing ordering and no pivoting. By Sylvester's law of inertia the number of negative
entries of D is the exact number of eigenvalues of L phi = lambda M phi below s (M is
positive definite). The same factorisation applies (L - s M)^-1 for shift-invert Lanczos;
its factorisation and triangular solves were about 2x faster than SuperLU's at 5000 points,
and the solves dominate a Lanczos band (whole solve 1.3-1.5x, bench/eigensolve.py
--compare). Without pivoting the factorisation of an indefinite K can be unstable, so every
factorisation is checked on a random right-hand side; if the check fails we fall back to
SuperLU's partial pivoting, which solves accurately but gives no inertia.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import qdldl
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, splu

from core.errors import SolverError

__all__ = ["ShiftFactorisation", "factorise_shifted"]

# Largest relative residual ||K x - b|| / ||b|| accepted from a factorisation. Well-placed
# shifts give ~1e-12; a shift sitting on an eigenvalue or an unstable pivot gives much more.
_RESIDUAL_LIMIT = 1e-8


class Solves(Protocol):
    """A factorisation: qdldl's ``Solver`` or SciPy's ``SuperLU``."""

    def solve(self, rhs: np.ndarray) -> np.ndarray: ...


@dataclass
class ShiftFactorisation:
    """Sparse LU of ``stiffness - shift * mass``.

    Attributes
    ----------
    shift : float
        s.
    lu : qdldl.Solver or scipy.sparse.linalg.SuperLU
        The factorisation (anything with ``solve(b)``).
    inertia : int or None
        Number of eigenvalues below ``shift`` (None when pivoting made it unavailable).
    residual : float
        Relative residual of a random test solve.
    seconds : float
        Time spent factorising (including the fallback, if any).
    """

    shift: float
    lu: Solves
    inertia: int | None
    residual: float
    seconds: float
    size: int = 0

    def inverse_operator(self) -> LinearOperator:
        """(L - s M)^-1 as a LinearOperator, for ``eigsh(..., OPinv=...)``."""
        size = self.size
        return LinearOperator((size, size), matvec=self.lu.solve, dtype=np.float64)


def _relative_residual(matrix: sp.csc_matrix, lu: Solves) -> float:
    """||K x - b|| / ||b|| for a fixed random b, a cheap check of the factorisation."""
    rhs = np.random.default_rng(12345).standard_normal(matrix.shape[0])
    solution = lu.solve(rhs)
    if not np.all(np.isfinite(solution)):
        return float("inf")
    return float(np.linalg.norm(matrix @ solution - rhs) / np.linalg.norm(rhs))


def _symmetric_ldl(matrix: sp.csc_matrix) -> tuple[Solves, int | None]:
    """No-pivot LDL^T with an AMD ordering, and the inertia it gives."""
    ldl = qdldl.Solver(matrix)  # raises RuntimeError on an exactly zero pivot
    diagonal = ldl.factors()[1]
    # A zero or non-finite pivot means the count is unreliable.
    if np.all(np.isfinite(diagonal)) and np.all(diagonal != 0):
        return ldl, int(np.count_nonzero(diagonal < 0))
    return ldl, None


def factorise_shifted(
    stiffness: sp.spmatrix, mass: sp.spmatrix, shift: float
) -> ShiftFactorisation:
    """Factorise ``stiffness - shift * mass`` and count the eigenvalues below ``shift``.

    Parameters
    ----------
    stiffness, mass : (n, n) sparse
        L and M.
    shift : float
        s.

    Returns
    -------
    ShiftFactorisation
        ``inertia`` is None when the no-pivot factorisation was unsafe and SuperLU's
        pivoting was used instead.

    Raises
    ------
    core.errors.SolverError
        Neither factorisation solves accurately (K is singular to working precision).
    """
    start = time.perf_counter()
    matrix = sp.csc_matrix(stiffness - shift * mass)
    lu: Solves | None
    try:
        lu, inertia = _symmetric_ldl(matrix)
        residual = _relative_residual(matrix, lu)
    except RuntimeError:  # an exactly zero pivot
        lu, inertia, residual = None, None, float("inf")
    if residual > _RESIDUAL_LIMIT:
        try:
            lu, inertia = splu(matrix, permc_spec="MMD_AT_PLUS_A"), None
            residual = _relative_residual(matrix, lu)
        except RuntimeError as error:
            raise SolverError(f"factorisation of L - {shift:.6g} M failed: {error}") from error
    if residual > _RESIDUAL_LIMIT:
        raise SolverError(
            f"factorisation of L - {shift:.6g} M is inaccurate (residual {residual:.1e})"
        )
    assert lu is not None  # a finite residual came from a factorisation
    return ShiftFactorisation(
        shift=float(shift),
        lu=lu,
        inertia=inertia,
        residual=residual,
        seconds=time.perf_counter() - start,
        size=int(matrix.shape[0]),
    )
