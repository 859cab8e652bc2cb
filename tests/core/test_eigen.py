"""The banded shift-invert solver against one big solve, its bookkeeping and its checks."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from threadpoolctl import threadpool_info

from core.eigen import SpectralSolver, pin_blas_threads, smallest_eigenpairs
from core.eigen._banded import split_band
from core.eigen._factor import factorise_shifted
from core.errors import SolverError
from core.laplacian import build_laplacian
from tests.shapes import sphere_points, torus_points

REFERENCE_COUNT = 200


@pytest.fixture(scope="module")
def sphere() -> tuple[sp.spmatrix, sp.spmatrix]:
    return build_laplacian(sphere_points(2000, seed=5), "robust")


@pytest.fixture(scope="module")
def torus() -> tuple[sp.spmatrix, sp.spmatrix]:
    return build_laplacian(torus_points(2000, R=1.0, r=0.4, seed=6), "robust")


@pytest.fixture(scope="module")
def references(sphere, torus) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    return {
        "sphere": smallest_eigenpairs(*sphere, REFERENCE_COUNT),
        "torus": smallest_eigenpairs(*torus, REFERENCE_COUNT),
    }


def clusters(eigenvalues: np.ndarray, rtol: float = 1e-6) -> list[slice]:
    """Index ranges of eigenvalues closer than ``rtol`` (relative) to their neighbour."""
    scale = max(float(eigenvalues[-1]), 1.0)
    breaks = np.flatnonzero(np.diff(eigenvalues) > rtol * scale) + 1
    edges = [0, *breaks.tolist(), eigenvalues.size]
    return [slice(start, stop) for start, stop in zip(edges[:-1], edges[1:], strict=True)]


# Band sizes 7 and 10 put band edges inside the sphere's 2l + 1 multiplets (split by the
# sampling into near-degenerate clusters); 50 is the production default.
@pytest.mark.slow
@pytest.mark.parametrize(("shape", "band_size"), [("sphere", 7), ("sphere", 10), ("torus", 50)])
def test_banded_continuation_equals_one_big_solve(request, references, shape, band_size):
    stiffness, mass = request.getfixturevalue(shape)
    solver = SpectralSolver(stiffness, mass, band_size=band_size)
    for count in (50, 120, REFERENCE_COUNT):
        eigenvalues, eigenvectors = solver.solve(count)
        assert eigenvalues.shape == (count,) and eigenvectors.shape == (stiffness.shape[0], count)
    reference_values, reference_vectors = references[shape]
    scale = reference_values[-1]
    # Same eigenvalues, none missed or repeated (a duplicate or a miss shifts every later one).
    np.testing.assert_allclose(eigenvalues, reference_values, rtol=1e-8, atol=1e-8 * scale)
    assert np.all(np.diff(solver.eigenvalues_) >= 0)
    # M-orthonormal.
    gram = eigenvectors.T @ (mass @ eigenvectors)
    assert np.abs(gram - np.eye(REFERENCE_COUNT)).max() < 1e-8
    # Same invariant subspace per eigenvalue cluster: all principal cosines are 1.
    for cluster in clusters(reference_values)[:-1]:  # the last may be cut at 200
        overlap = reference_vectors[:, cluster].T @ (mass @ eigenvectors[:, cluster])
        cosines = np.linalg.svd(overlap, compute_uv=False)
        assert cosines.min() > 1 - 1e-6


def test_counters_and_no_work_for_known_counts(torus):
    solver = SpectralSolver(*torus, band_size=30)
    assert (solver.solver_calls_, solver.factorisations_, len(solver.bands_)) == (0, 0, 0)
    first_values, _ = solver.solve(40)
    assert solver.solver_calls_ == 1
    assert solver.factorisations_ == len({band.shift for band in solver.bands_}) >= 2
    assert sum(band.count for band in solver.bands_) == solver.eigenvalues_.size >= 40
    bands, factorisations = len(solver.bands_), solver.factorisations_
    for count in (40, 25, solver.eigenvalues_.size):
        values, _ = solver.solve(count)
        np.testing.assert_array_equal(values, solver.eigenvalues_[:count])
    assert (solver.solver_calls_, len(solver.bands_), solver.factorisations_) == (
        1,
        bands,
        factorisations,
    )
    solver.solve(100)
    assert solver.solver_calls_ == 2
    np.testing.assert_array_equal(solver.eigenvalues_[:40], first_values)
    assert len(solver.bands_) > bands


def test_small_request_computes_one_small_band(torus):
    solver = SpectralSolver(*torus, band_size=50)
    solver.solve(10)
    assert len(solver.bands_) == 1 and solver.bands_[0].requested < 50
    assert solver.bands_[0].inertia == 0  # nothing below the first (negative) shift


def test_inertia_check_fires_when_an_eigenpair_is_missing(torus):
    solver = SpectralSolver(*torus, band_size=20)
    solver.solve(40)
    keep = np.arange(solver.eigenvalues_.size) != 17
    solver.eigenvalues_ = solver.eigenvalues_[keep]  # tamper: lose one eigenpair
    solver.eigenvectors_ = solver.eigenvectors_[:, keep]
    with pytest.raises(SolverError, match="inertia"):
        solver.solve(80)


def test_factorisation_inertia_counts_eigenvalues_below_the_shift(torus, references):
    stiffness, mass = torus
    eigenvalues = references["torus"][0]
    for index in (0, 1, 37, 150):
        shift = 0.5 * (eigenvalues[index] + eigenvalues[index + 1])
        factor = factorise_shifted(stiffness, mass, shift)
        assert factor.inertia == index + 1
        assert factor.residual < 1e-8


def test_tied_cluster_at_the_band_edge_is_dropped():
    # Shift 2, radius 1: window (1, 3); the two copies of 3 sit on the edge (a third copy
    # may be missing), so only 2 is new and the bound moves to the middle of the gap.
    split = split_band(np.array([1.0, 2.0, 3.0, 3.0]), shift=2.0, lower=1.5)
    assert not split.missed_gap
    assert (split.start, split.stop, split.new_lower) == (1, 2, 2.5)
    # A window that does not reach the bound is a miss unless inertia certified the gap.
    assert split_band(np.array([5.0, 6.0]), shift=5.5, lower=1.0).missed_gap
    assert split_band(np.array([5.0, 6.0]), shift=5.5, lower=1.0, gap_certified=True).accepted


def test_small_problems_use_a_dense_solve_and_cap_at_n():
    stiffness, mass = build_laplacian(sphere_points(150, seed=1), "robust")
    solver = SpectralSolver(stiffness, mass)
    eigenvalues, eigenvectors = solver.solve(500)
    assert eigenvalues.shape == (150,) and eigenvectors.shape == (150, 150)
    assert solver.factorisations_ == 0 and solver.solver_calls_ == 1
    np.testing.assert_allclose(eigenvectors.T @ (mass @ eigenvectors), np.eye(150), atol=1e-8)
    assert abs(eigenvalues[0]) < 1e-8


def test_parameters_are_checked_at_solve_time(torus):
    solver = SpectralSolver(*torus, shift=0.5)  # the constructor only stores
    assert not hasattr(solver, "eigenvalues_")
    with pytest.raises(ValueError, match="negative"):
        solver.solve(10)
    with pytest.raises(ValueError, match="at least 1"):
        SpectralSolver(*torus).solve(0)


def test_pin_blas_threads_limits_blas_pools():
    with pin_blas_threads(1):
        blas = [pool for pool in threadpool_info() if pool["user_api"] == "blas"]
        assert blas and all(pool["num_threads"] == 1 for pool in blas)


def test_multi_component_shape_zero_eigenvalues_and_continued_rounds():
    # Three separate spheres: three zero eigenvalues (one constant per component), then
    # every sphere multiplet three times over; band size 5 cuts those clusters.
    points = np.vstack([sphere_points(700, seed=s) + [4.0 * s, 0.0, 0.0] for s in range(3)])
    stiffness, mass = build_laplacian(points, "robust")
    reference_values, reference_vectors = smallest_eigenpairs(stiffness, mass, 60)
    solver = SpectralSolver(stiffness, mass, band_size=5)
    for count in (2, 20, 60):  # the first round stops inside the zero cluster
        eigenvalues, eigenvectors = solver.solve(count)
    scale = reference_values[-1]
    assert np.all(np.abs(eigenvalues[:3]) < 1e-8 * scale) and eigenvalues[3] > 1e-3 * scale
    np.testing.assert_allclose(eigenvalues, reference_values, rtol=1e-8, atol=1e-8 * scale)
    for cluster in clusters(reference_values)[:-1]:
        overlap = reference_vectors[:, cluster].T @ (mass @ eigenvectors[:, cluster])
        assert np.linalg.svd(overlap, compute_uv=False).min() > 1 - 1e-6


def test_a_shift_on_an_eigenvalue_is_refused_not_miscounted(torus):
    # L is singular (constants): at s = 0 neither LDL^T nor pivoting LU solves accurately.
    with pytest.raises(SolverError, match="factorisation"):
        factorise_shifted(*torus, 0.0)


def test_the_mass_operator_is_the_sparse_product_bit_for_bit(torus):
    """ARPACK gets a diagonal M as one elementwise product (core.eigen._solver): the same
    numbers as the sparse product, so every descriptor stays bit for bit what it was."""
    from core.eigen._solver import _mass_operator

    _, mass = torus
    vector = np.random.default_rng(3).standard_normal(mass.shape[0])
    operator = _mass_operator(mass)
    assert not sp.issparse(operator)
    assert np.array_equal(operator.matvec(vector), mass @ vector)
    assert np.array_equal(operator.matvec(vector[:, None]).ravel(), mass @ vector)
    # A mass with off-diagonal terms (a consistent, not lumped, mass) is used as given.
    coupled = mass + sp.diags(np.full(mass.shape[0] - 1, 1e-6), 1)
    coupled = (coupled + coupled.T).tocsr()
    assert _mass_operator(coupled) is coupled
