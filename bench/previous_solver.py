"""The previous eigen-solver, for baselines measured in the same run.

The previous solver factored each shift by SuperLU without pivoting in symmetric mode (U = D Lᵀ,
the inertia from the signs of D) and ARPACK ran with its default basis of 2k + 1 vectors per
band. ``use_previous_solver()`` switches ``core.eigen`` back to that for the rest of the
process (benchmarks run each baseline in a process of its own).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

import core.eigen._factor as factor_module
import core.eigen._solver as solver_module

__all__ = ["superlu_ldl", "use_previous_solver"]

# ARPACK's default basis, 2k + 1, as a multiple of the band size.
PREVIOUS_BASIS_FACTOR = 2.0


def superlu_ldl(matrix: sp.csc_matrix) -> tuple[object, int | None]:
    """SuperLU without pivoting in symmetric mode, and the inertia from its pivots."""
    lu = splu(
        matrix, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
    )
    pivots = lu.U.diagonal()
    congruent = np.array_equal(lu.perm_r, lu.perm_c)
    if congruent and np.all(np.isfinite(pivots)) and np.all(pivots != 0):
        return lu, int(np.count_nonzero(pivots < 0))
    return lu, None


def use_previous_solver() -> None:
    """Make ``SpectralSolver`` factor and iterate as the previous solver did (this process only)."""
    factor_module._symmetric_ldl = superlu_ldl
    solver_module._BASIS_FACTOR = PREVIOUS_BASIS_FACTOR
