"""The adaptive cutoff on synthetic spectra, where n can be computed by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.cutoff import AdaptiveCutoff, FixedCutoff, contribution_cutoff, make_cutoff
from core.settings import CutoffSettings


class SpectrumSolver:
    """A solver over a known spectrum that counts calls the way SpectralSolver does."""

    def __init__(self, spectrum: np.ndarray) -> None:
        self.spectrum = np.asarray(spectrum, dtype=np.float64)
        self.found = 0
        self.solver_calls_ = 0
        self.requests: list[int] = []

    @property
    def eigenvalues_(self) -> np.ndarray:
        return self.spectrum[: self.found]

    def solve(self, count: int) -> tuple[np.ndarray, np.ndarray]:
        if count > self.found:
            self.solver_calls_ += 1
            self.requests.append(count)
            self.found = count
        return self.spectrum[:count], np.zeros((3, count))


def weyl_spectrum(length: int = 4000, slope: float = 4 * np.pi, noise: float = 0.0) -> np.ndarray:
    rng = np.random.default_rng(7)
    spectrum = slope * np.arange(length) + noise * slope * rng.standard_normal(length)
    spectrum[0] = 0.0
    return np.sort(spectrum)


def hand_cutoff_linear(slope: float, xi: float, t: float) -> int:
    """First n with exp(-t s (n-2)) - exp(-t s (n-1)) < xi for lambda_i = s (i - 1)."""
    a = t * slope
    # exp(-a (n - 2)) (1 - exp(-a)) < xi  <=>  n - 2 > log((1 - exp(-a)) / xi) / a
    return math.floor(math.log((1 - math.exp(-a)) / xi) / a) + 3


@pytest.mark.parametrize(("xi", "t"), [(1e-10, 0.01), (1e-8, 0.01), (1e-12, 0.02), (1e-6, 0.005)])
def test_contribution_cutoff_matches_hand_computation(xi: float, t: float) -> None:
    spectrum = weyl_spectrum()
    assert contribution_cutoff(spectrum, xi, t) == hand_cutoff_linear(4 * np.pi, xi, t)


def test_contribution_cutoff_none_when_never_reached() -> None:
    assert contribution_cutoff(np.array([0.0, 1.0, 2.0]), 1e-12, 1e-3) is None


@pytest.mark.parametrize(("xi", "t"), [(1e-10, 0.01), (1e-8, 0.01), (1e-6, 0.008)])
def test_adaptive_finds_hand_computed_n_in_two_calls(xi: float, t: float) -> None:
    expected = hand_cutoff_linear(4 * np.pi, xi, t)
    assert 80 <= expected <= 500  # the case is not decided by the clamp
    solver = SpectrumSolver(weyl_spectrum())
    result = AdaptiveCutoff(xi=xi, t=t, seed=50, n_min=80, n_max=500).select(solver)
    assert result.n == expected
    assert result.solver_calls == 2  # the seed, then n + margin
    assert solver.requests == [50, expected + 10]
    assert result.predicted[0] == expected
    assert result.eigenvalues.size == expected + 10


def test_adaptive_on_noisy_weyl_spectrum_needs_at_most_two_calls_after_seed() -> None:
    spectrum = weyl_spectrum(noise=0.3)
    expected = contribution_cutoff(
        np.polynomial.polynomial.polyval(
            np.arange(1, 2001),
            np.polynomial.polynomial.polyfit(np.arange(1, 2001), spectrum[:2000], 2),
        ),
        1e-10,
        0.01,
    )
    solver = SpectrumSolver(spectrum)
    result = AdaptiveCutoff(xi=1e-10, t=0.01).select(solver)
    assert result.solver_calls <= 3
    assert abs(result.n - expected) <= 3


def test_adaptive_clamps_to_n_min_and_n_max() -> None:
    # Large t: the criterion is met almost at once, so n_min decides.
    low = AdaptiveCutoff(xi=1e-10, t=1.0, n_min=80).select(SpectrumSolver(weyl_spectrum()))
    assert low.n == 80
    assert low.predicted[0] < 80
    # Tiny t: the criterion is met far beyond n_max, which decides.
    solver = SpectrumSolver(weyl_spectrum())
    high = AdaptiveCutoff(xi=1e-10, t=1e-4, n_max=300).select(solver)
    assert high.n == 300
    assert high.predicted[0] > 300
    assert solver.found == 300  # no eigenpair beyond the clamp is computed


def test_adaptive_refits_when_the_seed_underestimates() -> None:
    # A spectrum that bends down after the seed: the first prediction is too small, the
    # check on computed eigenvalues must catch it and ask again.
    index = np.arange(3000, dtype=np.float64)
    spectrum = 4 * np.pi * np.where(index < 60, index, 60 + (index - 60) * 0.5)
    solver = SpectrumSolver(spectrum)
    result = AdaptiveCutoff(xi=1e-10, t=0.01).select(solver)
    truth = contribution_cutoff(spectrum, 1e-10, 0.01)
    assert result.predicted[0] < truth - 50  # the seed alone is badly wrong here
    assert result.n == truth  # ... and the refits on computed eigenvalues repair it
    assert result.eigenvalues.size >= truth
    assert 3 <= result.solver_calls <= 5


def test_fixed_cutoff_returns_exactly_n() -> None:
    solver = SpectrumSolver(weyl_spectrum())
    result = FixedCutoff(300).select(solver)
    assert result.n == 300
    assert result.solver_calls == 1
    assert result.eigenvalues.size == 300


def test_make_cutoff_follows_settings() -> None:
    assert isinstance(make_cutoff(CutoffSettings(mode="fixed", n=120)), FixedCutoff)
    adaptive = make_cutoff(CutoffSettings(xi=1e-9, t=0.02, n_min=90))
    assert isinstance(adaptive, AdaptiveCutoff)
    assert (adaptive.xi, adaptive.t, adaptive.n_min) == (1e-9, 0.02, 90)


@pytest.mark.parametrize(
    "bad",
    [
        {"mode": "magic"},
        {"xi": 0.0},
        {"t": -1.0},
        {"n_min": 600, "n_max": 500},
        {"margin": -1},
    ],
)
def test_invalid_cutoff_settings_are_refused(bad: dict) -> None:
    with pytest.raises(ValueError):
        CutoffSettings(**bad).validate()
