"""The adaptive cutoff on synthetic spectra, where n can be computed by hand."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from core.cutoff import (
    AdaptiveCutoff,
    CutoffRecord,
    FixedCutoff,
    contribution_cutoff,
    make_cutoff,
    window_cutoff,
)
from core.cutoff_predictor import CutoffPredictor, shape_features
from core.settings import CutoffSettings


class SpectrumSolver:
    """A solver over a known spectrum that counts calls the way SpectralSolver does."""

    def __init__(self, spectrum: np.ndarray, overshoot: int = 0) -> None:
        self.spectrum = np.asarray(spectrum, dtype=np.float64)
        self.overshoot = overshoot
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
            # Like a banded solver, may find more than asked for (``overshoot`` extra).
            self.found = min(count + self.overshoot, self.spectrum.size)
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
    assert low.predicted == [] and low.solver_calls == 2  # the seed decided; then n_min
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
    truth = window_cutoff(spectrum, 1e-10, 0.01, seed=50, margin=10, n_min=80, n_max=500)
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


def bent_spectrum() -> np.ndarray:
    """Weyl-like with noise and a bend after 60: the seed's extrapolation is wrong."""
    index = np.arange(3000, dtype=np.float64)
    spectrum = 4 * np.pi * np.where(index < 60, index, 60 + (index - 60) * 0.5)
    noise = 0.3 * 4 * np.pi * np.random.default_rng(3).standard_normal(index.size)
    return np.sort(np.maximum(spectrum + noise, 0.0))


SPECTRA = {
    "weyl": weyl_spectrum(),
    "noisy": weyl_spectrum(noise=0.3),
    "bent": bent_spectrum(),
    "multiplets": np.repeat(4 * np.pi * np.arange(1000), 3)[:3000],  # exact triple ties
}


@pytest.mark.parametrize("name", sorted(SPECTRA))
def test_n_is_a_function_of_the_spectrum_alone(name: str) -> None:
    spectrum = SPECTRA[name]
    cutoff = AdaptiveCutoff(xi=1e-10, t=0.01)
    truth = cutoff.decide(spectrum)
    assert truth is not None and 80 <= truth <= 500
    # Whatever the solver computed beyond what was asked, the seeded path finds the same n.
    for overshoot in (0, 7, 45, 400):
        assert cutoff.select(SpectrumSolver(spectrum, overshoot=overshoot)).n == truth
    # Too few eigenvalues to see the window of n* -> undecided, never a wrong n.
    assert cutoff.decide(spectrum[: truth + cutoff.margin - 1]) is None
    assert cutoff.decide(spectrum[: truth + cutoff.margin]) == truth


@pytest.mark.parametrize("name", sorted(SPECTRA))
@pytest.mark.parametrize("error", [-150, -40, -11, -10, -5, 0, 5, 10, 40, 300, 10_000, -10_000])
def test_predicted_path_gives_the_seeded_n(name: str, error: int) -> None:
    spectrum = SPECTRA[name]
    cutoff = AdaptiveCutoff(xi=1e-10, t=0.01)
    seeded = cutoff.select(SpectrumSolver(spectrum))
    solver = SpectrumSolver(spectrum)
    predicted = cutoff.select(solver, prediction=max(seeded.n + error, 0))
    assert predicted.n == seeded.n  # a wrong prediction costs calls, never changes n
    assert predicted.prediction == max(seeded.n + error, 0)
    assert seeded.prediction is None and seeded.prediction_held is None
    assert predicted.prediction_held == (predicted.solver_calls == 1)
    if -cutoff.margin <= error <= cutoff.margin:  # about right: one call decides
        assert predicted.prediction_held and predicted.solver_calls == 1
        assert solver.requests == [min(seeded.n + error + 2 * cutoff.margin, cutoff.n_max)]
    if error < -cutoff.margin:  # low: at least one more call
        assert not predicted.prediction_held


def naive_window_cutoff(spectrum: np.ndarray, xi: float, t: float) -> int:
    """The documented rule, one polyfit per n (seed 50, margin 10, clamp 80-500)."""
    for n in range(2, 501):
        window = int(np.clip(n + 10, 50, 500))
        index = np.arange(1, window + 1)
        fit = np.polynomial.polynomial.polyfit(index, spectrum[:window], 2)
        smooth = np.maximum.accumulate(np.polynomial.polynomial.polyval(np.arange(1, n + 1), fit))
        if np.exp(-t * smooth[-2]) - np.exp(-t * smooth[-1]) < xi:
            return int(np.clip(n, 80, 500))
    return 500


@pytest.mark.parametrize("name", sorted(SPECTRA))
@pytest.mark.parametrize(("xi", "t"), [(1e-10, 0.01), (1e-8, 0.02), (1e-10, 0.004)])
def test_vectorised_rule_matches_the_naive_rule(name: str, xi: float, t: float) -> None:
    spectrum = SPECTRA[name]
    assert AdaptiveCutoff(xi=xi, t=t).decide(spectrum) == naive_window_cutoff(spectrum, xi, t)


def test_predictor_without_data_falls_back_to_the_seed() -> None:
    assert CutoffPredictor().predict(np.zeros(4)) is None
    empty = CutoffPredictor().fit(np.empty((0, 4)), np.empty(0))
    assert empty.n_samples_ == 0 and empty.predict(np.zeros(4)) is None
    spectrum = SPECTRA["noisy"]
    solver = SpectrumSolver(spectrum)
    result = AdaptiveCutoff(xi=1e-10, t=0.01).select(solver, prediction=empty.predict(np.ones(4)))
    assert solver.requests[0] == 50 and result.prediction is None


def test_predictor_returns_the_median_n_of_the_nearest_models() -> None:
    features = np.array([[0.0, 0.0], [0.1, 0.0], [0.0, 0.1], [5.0, 5.0], [5.1, 5.0]])
    n = np.array([100, 110, 120, 300, 310])
    predictor = CutoffPredictor(neighbours=3).fit(features, n)
    assert predictor.predict(np.array([0.05, 0.05])) == 110
    assert predictor.predict(np.array([5.0, 5.1])) == 300  # the two near ones and 120
    assert predictor.predict(np.array([np.nan, 0.0])) is None  # bad features: seed round
    assert CutoffPredictor(neighbours=1).fit(features, n).predict(np.array([5.1, 5.0])) == 310


PART_NAMES = ("teapot.stl", "angle_block.STL", "plate_holes.STL")


@pytest.fixture(scope="module")
def part_operators() -> dict[str, tuple]:
    from core.io import load_points
    from core.pipeline import normalised_operators
    from core.settings import EngineSettings

    settings = EngineSettings(max_points=1000)
    parts = Path(__file__).parents[1] / "fixtures" / "parts"
    operators = {}
    for name in PART_NAMES:
        points = load_points(parts / name, max_points=1000).points
        points, stiffness, mass = normalised_operators(points, settings)
        operators[name] = (stiffness, mass, shape_features(points, mass))
    return operators


@pytest.mark.slow
def test_predicted_path_gives_the_seeded_n_on_real_parts(part_operators) -> None:
    from core.eigen import SpectralSolver

    cutoff = AdaptiveCutoff(xi=1e-10, t=0.02, seed=20, n_min=20, n_max=200)
    seeded = {name: cutoff.select(SpectralSolver(*ops[:2])) for name, ops in part_operators.items()}
    assert len({result.n for result in seeded.values()}) > 1  # the parts differ
    features = np.array([ops[2] for ops in part_operators.values()])
    truth = np.array([result.n for result in seeded.values()])
    predictors = {
        "leave-one-out": None,
        "badly low": CutoffPredictor().fit(features, np.full(len(truth), 2)),
        "badly high": CutoffPredictor().fit(features, np.full(len(truth), 10_000)),
    }
    for name, (stiffness, mass, own) in part_operators.items():
        expected = seeded[name].n
        for label, predictor in predictors.items():
            if predictor is None:
                keep = [other != name for other in part_operators]
                predictor = CutoffPredictor(neighbours=1).fit(features[keep], truth[keep])
            solver = SpectralSolver(stiffness, mass)
            result = cutoff.select(solver, prediction=predictor.predict(own))
            assert result.n == expected, (name, label)
            assert result.prediction is not None and result.prediction_held == (
                result.solver_calls == 1
            )
        exact = cutoff.select(SpectralSolver(stiffness, mass), prediction=expected)
        assert exact.n == expected and exact.prediction_held and exact.solver_calls == 1


def test_the_cutoff_record_round_trips_and_reads_records_stored_before_it() -> None:
    solver = SpectrumSolver(np.arange(1, 400, dtype=float))
    result = make_cutoff(CutoffSettings(xi=1e-10, t=1e-3, seed=20, n_min=5, n_max=300)).select(
        solver
    )
    record = result.record(np.array([8.0, 0.3, 0.7, 0.5]))
    stored = json.loads(json.dumps(record.to_json()))  # what the database gives back
    assert CutoffRecord.from_json(stored) == record
    assert stored["n"] == result.n and stored["xi"] == 1e-10 and stored["n_min"] == 5
    assert stored["features"] == [8.0, 0.3, 0.7, 0.5]
    # Rows written before the record kept the adaptive parameters under "params", and a
    # fixed cutoff's n there too.
    legacy = {"mode": "adaptive", "n": 120, "solver_calls": 2, "predicted": [118],
              "params": {"xi": 1e-10, "t": 0.01, "seed": 50, "n_min": 80, "n_max": 500,
                         "margin": 10}}
    read = CutoffRecord.from_json(legacy)
    assert (read.n, read.xi, read.n_max, read.margin, read.predicted) == (120, 1e-10, 500, 10,
                                                                          [118])
    fixed = CutoffRecord.from_json({"mode": "fixed", "n": 300, "solver_calls": 1,
                                    "params": {"n": 300}, "predicted": []})
    assert fixed.n == 300 and fixed.xi is None
