"""One sparse factorisation of K = L - s M per shift s, used twice.

With a symmetric fill-reducing ordering and no pivoting, SuperLU computes K = P^T L D L^T P
with U = D L^T, so the diagonal of U holds the pivots D. By Sylvester's law of inertia the
number of negative pivots is the exact number of eigenvalues of L phi = lambda M phi below s
(M is positive definite). The same factorisation applies (L - s M)^-1 for shift-invert
Lanczos. Without pivoting the factorisation of an indefinite K can be unstable, so every
factorisation is checked on a random right-hand side; if the check fails we fall back to
SuperLU's partial pivoting, which solves accurately but gives no inertia.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, splu

from core.errors import SolverError

__all__ = ["ShiftFactorisation", "factorise_shifted"]

# Largest relative residual ||K x - b|| / ||b|| accepted from a factorisation. Well-placed
# shifts give ~1e-12; a shift sitting on an eigenvalue or an unstable pivot gives much more.
_RESIDUAL_LIMIT = 1e-8


@dataclass
class ShiftFactorisation:
    """Sparse LU of ``stiffness - shift * mass``.

    Attributes
    ----------
    shift : float
        s.
    lu : scipy.sparse.linalg.SuperLU
        The factorisation.
    inertia : int or None
        Number of eigenvalues below ``shift`` (None when pivoting made it unavailable).
    residual : float
        Relative residual of a random test solve.
    seconds : float
        Time spent factorising (including the fallback, if any).
    """

    shift: float
    lu: object
    inertia: int | None
    residual: float
    seconds: float

    def inverse_operator(self) -> LinearOperator:
        """(L - s M)^-1 as a LinearOperator, for ``eigsh(..., OPinv=...)``."""
        size = self.lu.shape[0]
        return LinearOperator((size, size), matvec=self.lu.solve, dtype=np.float64)


def _relative_residual(matrix: sp.csc_matrix, lu: object) -> float:
    """||K x - b|| / ||b|| for a fixed random b, a cheap check of the factorisation."""
    rhs = np.random.default_rng(12345).standard_normal(matrix.shape[0])
    solution = lu.solve(rhs)
    if not np.all(np.isfinite(solution)):
        return float("inf")
    return float(np.linalg.norm(matrix @ solution - rhs) / np.linalg.norm(rhs))


def _symmetric_ldl(matrix: sp.csc_matrix) -> tuple[object, int | None]:
    """No-pivot LU with a symmetric ordering; the inertia if it is an LDL^T in disguise."""
    lu = splu(
        matrix,
        permc_spec="MMD_AT_PLUS_A",
        diag_pivot_thresh=0.0,
        options={"SymmetricMode": True},
    )
    pivots = lu.U.diagonal()
    # Equal row and column permutations make P K P^T = L U a congruence; then the signs of
    # the pivots are the inertia. A zero or non-finite pivot means the count is unreliable.
    congruent = np.array_equal(lu.perm_r, lu.perm_c)
    if congruent and np.all(np.isfinite(pivots)) and np.all(pivots != 0):
        return lu, int(np.count_nonzero(pivots < 0))
    return lu, None


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
    try:
        lu, inertia = _symmetric_ldl(matrix)
        residual = _relative_residual(matrix, lu)
    except RuntimeError:  # SuperLU reports an exactly singular pivot this way
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
    return ShiftFactorisation(
        shift=float(shift),
        lu=lu,
        inertia=inertia,
        residual=residual,
        seconds=time.perf_counter() - start,
    )
