"""HKS and WKS against closed forms on the sphere's spherical harmonics."""

from __future__ import annotations

import numpy as np
import pytest

from core.signatures import heat_kernel_signature, wave_kernel_signature, zero_eigenvalue_count


def sphere_harmonics(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Real spherical harmonics up to degree 2 on the unit sphere and their eigenvalues.

    Normalised for the surface measure (integral of Y^2 over the sphere = 1).
    """
    x, y, z = points.T
    c0, c1, c2 = np.sqrt(1 / (4 * np.pi)), np.sqrt(3 / (4 * np.pi)), np.sqrt(15 / (4 * np.pi))
    basis = [
        np.full_like(x, c0),
        c1 * x, c1 * y, c1 * z,
        c2 * x * y, c2 * y * z, c2 * x * z,
        c2 / 2 * (x**2 - y**2), np.sqrt(5 / (16 * np.pi)) * (3 * z**2 - 1),
    ]
    eigenvalues = np.array([0.0] + [2.0] * 3 + [6.0] * 5)
    return eigenvalues, np.column_stack(basis)


@pytest.fixture
def sphere() -> np.ndarray:
    points = np.random.default_rng(3).standard_normal((500, 3))
    return points / np.linalg.norm(points, axis=1, keepdims=True)


def test_hks_on_complete_multiplets_is_constant_and_matches_addition_theorem(sphere) -> None:
    eigenvalues, eigenvectors = sphere_harmonics(sphere)
    times = np.array([0.01, 0.1, 1.0])
    hks = heat_kernel_signature(eigenvalues, eigenvectors, times)
    # Addition theorem: sum_m Y_lm(x)^2 = (2l + 1) / 4 pi at every point of the sphere.
    expected = sum(
        (2 * degree + 1) / (4 * np.pi) * np.exp(-degree * (degree + 1) * times)
        for degree in range(3)
    )
    np.testing.assert_allclose(hks, np.broadcast_to(expected, hks.shape), rtol=1e-12)


def test_scaled_hks_has_unit_area_weighted_mean(sphere) -> None:
    eigenvalues, eigenvectors = sphere_harmonics(sphere)
    areas = np.full(len(sphere), 4 * np.pi / len(sphere))
    # Drop one of the three l=1 functions: the signature is no longer constant, but the
    # heat-trace scaled HKS must still average to 1 over the surface.
    keep = [0, 1, 4, 5, 8]
    scaled = heat_kernel_signature(
        eigenvalues[keep], eigenvectors[:, keep], np.geomspace(1e-3, 1, 7), scaled=True
    )
    mean = areas @ scaled  # integral of phi^2 is 1 for every mode
    np.testing.assert_allclose(mean, 1.0, atol=0.05)  # Monte Carlo quadrature of 500 points
    assert np.ptp(scaled[:, 0]) > 0.05  # not constant any more


def test_hks_decreases_with_time(sphere) -> None:
    eigenvalues, eigenvectors = sphere_harmonics(sphere)
    hks = heat_kernel_signature(eigenvalues, eigenvectors, np.geomspace(1e-3, 10, 12))
    assert np.all(np.diff(hks, axis=1) < 0)
    # Long time: only the constant mode survives, 1 / area.
    late = heat_kernel_signature(eigenvalues, eigenvectors, np.array([100.0]))
    np.testing.assert_allclose(late, 1 / (4 * np.pi), rtol=1e-9)


def test_wks_skips_zero_modes_and_is_a_weighted_average(sphere) -> None:
    eigenvalues, eigenvectors = sphere_harmonics(sphere)
    energies = np.log(np.array([2.0, 6.0, 1e6]))
    wks = wave_kernel_signature(eigenvalues, eigenvectors, energies, sigma=0.1)
    assert np.all(np.isfinite(wks))
    # At e = log 2 only the l=1 triplet has weight: sum_m Y_1m^2 / 3 = 1 / 4 pi.
    np.testing.assert_allclose(wks[:, 0], 1 / (4 * np.pi), rtol=1e-6)
    np.testing.assert_allclose(wks[:, 1], 1 / (4 * np.pi), rtol=1e-6)
    # Far above the computed spectrum there is (numerically) no support: zeros, not NaN.
    assert np.all(wks[:, 2] < 1e-12)


def test_zero_eigenvalue_count_counts_components() -> None:
    assert zero_eigenvalue_count(np.array([0.0, 1e-12, -1e-13, 3.0, 7.0])) == 3
    assert zero_eigenvalue_count(np.array([0.0, 2.0])) == 1
