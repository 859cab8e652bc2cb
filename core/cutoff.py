"""How many eigenpairs a model gets: the tunable model-adaptive cutoff (Williams & Ilies).

A fixed count captures a different part of the spectrum for every model and sampling. The
adaptive cutoff instead stops where the next eigenpair would change a heat kernel sum by
less than ``xi``::

    first n with  exp(-t lambda_{n-1}) - exp(-t lambda_n) < xi

It computes a seed of eigenvalues, fits a quadratic ``lambda(i)`` to them to predict the
ones not yet computed, asks the solver for ``n + margin`` eigenpairs, refits on everything
found and repeats until the predicted ``n`` lies inside the computed range; ``n`` is then
clamped to ``[n_min, n_max]``. On Weyl-like spectra that is the seed plus one solver call.

The solver is anything with ``solve(count) -> (eigenvalues, eigenvectors)`` and a
``solver_calls_`` counter, such as ``core.eigen.SpectralSolver``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from core.settings import CutoffSettings

__all__ = [
    "AdaptiveCutoff",
    "CutoffResult",
    "FixedCutoff",
    "contribution_cutoff",
    "make_cutoff",
]

# Rounds after which the adaptive cutoff gives up refining and clamps; each round grows the
# computed spectrum, so this only guards against a pathological, ever-receding prediction.
_MAX_ROUNDS = 8


class EigenSolver(Protocol):
    solver_calls_: int

    def solve(self, count: int) -> tuple[np.ndarray, np.ndarray]: ...


@dataclass
class CutoffResult:
    """What a cutoff decided.

    Attributes
    ----------
    mode : str
        ``"adaptive"`` or ``"fixed"``.
    n : int
        Eigenpairs used by the signatures.
    solver_calls : int
        Calls to the eigen-solver that computed something (the seed counts as one).
    predicted : list of int
        Unclamped ``n`` predicted in each round (empty for a fixed cutoff).
    eigenvalues : (m,) float
        Every eigenvalue computed, ``m >= n``.
    params : dict
        Parameters of the cutoff, for the record.
    """

    mode: str
    n: int
    solver_calls: int
    predicted: list[int] = field(default_factory=list)
    eigenvalues: np.ndarray = field(default_factory=lambda: np.empty(0))
    params: dict[str, Any] = field(default_factory=dict)


def contribution_cutoff(eigenvalues: np.ndarray, xi: float, t: float) -> int | None:
    """First ``n`` (1-based count) where the contribution step drops below ``xi``.

    Parameters
    ----------
    eigenvalues : (m,) float
        Ascending eigenvalues, computed or predicted.
    xi : float
        Threshold on ``exp(-t lambda_{n-1}) - exp(-t lambda_n)``.
    t : float
        Time at which the heat kernel contributions are compared.

    Returns
    -------
    n : int or None
        ``None`` when no step in ``eigenvalues`` is below ``xi``.
    """
    heat = np.exp(-t * np.asarray(eigenvalues, dtype=np.float64))
    steps = heat[:-1] - heat[1:]  # steps[j] belongs to n = j + 2
    below = np.flatnonzero(steps < xi)
    return int(below[0]) + 2 if below.size else None


def _quadratic_prediction(eigenvalues: np.ndarray, length: int) -> np.ndarray:
    """Fit ``lambda(i) = a + b i + c i^2`` to ``eigenvalues`` and evaluate it for i < length.

    The prediction is made non-decreasing: a spectrum is sorted, and a fit that dips would
    fake a zero contribution step.
    """
    index = np.arange(1, eigenvalues.size + 1, dtype=np.float64)
    coefficients = np.polynomial.polynomial.polyfit(index, eigenvalues, 2)
    predicted = np.polynomial.polynomial.polyval(np.arange(1, length + 1), coefficients)
    return np.maximum.accumulate(predicted)


class AdaptiveCutoff:
    """The Williams & Ilies model-adaptive cutoff (method.md section 4).

    Parameters
    ----------
    xi : float
        Contribution threshold; smaller asks for more eigenpairs.
    t : float
        Heat kernel time of the criterion (the smallest time of interest).
    seed : int
        Eigenpairs computed before the first prediction.
    n_min, n_max : int
        Clamp of the result.
    margin : int
        Extra eigenpairs computed beyond the predicted n, against under-estimates.
    """

    mode = "adaptive"

    def __init__(
        self,
        xi: float,
        t: float,
        seed: int = 50,
        n_min: int = 80,
        n_max: int = 500,
        margin: int = 10,
    ) -> None:
        self.xi = xi
        self.t = t
        self.seed = seed
        self.n_min = n_min
        self.n_max = n_max
        self.margin = margin

    def params(self) -> dict[str, Any]:
        return {
            "xi": self.xi,
            "t": self.t,
            "seed": self.seed,
            "n_min": self.n_min,
            "n_max": self.n_max,
            "margin": self.margin,
        }

    def predict(self, eigenvalues: np.ndarray) -> int:
        """Unclamped n predicted from the eigenvalues found so far (n_max * 4 if beyond)."""
        horizon = 4 * self.n_max
        predicted = _quadratic_prediction(np.asarray(eigenvalues, dtype=np.float64), horizon)
        n = contribution_cutoff(predicted, self.xi, self.t)
        return horizon if n is None else n

    def select(self, solver: EigenSolver) -> CutoffResult:
        """Run the cutoff on ``solver``; the solver keeps every eigenpair it computed."""
        calls_before = solver.solver_calls_
        # Every fit uses all eigenvalues found so far, including any a band found beyond the
        # count asked for: more data for the fit, at no cost.
        eigenvalues = _all_eigenvalues(solver, solver.solve(self.seed)[0])
        predictions: list[int] = []
        n = self.n_max
        for _ in range(_MAX_ROUNDS):
            predicted = self.predict(eigenvalues)
            predictions.append(predicted)
            n = int(np.clip(predicted, self.n_min, self.n_max))
            # Done when the criterion is met inside the computed range, or the clamp decides.
            if predicted <= eigenvalues.size or n == self.n_max:
                break
            solved, _ = solver.solve(min(n + self.margin, self.n_max))
            eigenvalues = _all_eigenvalues(solver, solved)
        eigenvalues, _ = solver.solve(n)  # no work unless a clamp asks for more
        return CutoffResult(
            mode=self.mode,
            n=n,
            solver_calls=solver.solver_calls_ - calls_before,
            predicted=predictions,
            eigenvalues=_all_eigenvalues(solver, eigenvalues),
            params=self.params(),
        )


class FixedCutoff:
    """The baseline: exactly ``n`` eigenpairs for every model."""

    mode = "fixed"

    def __init__(self, n: int) -> None:
        self.n = n

    def select(self, solver: EigenSolver) -> CutoffResult:
        calls_before = solver.solver_calls_
        eigenvalues, _ = solver.solve(self.n)
        return CutoffResult(
            mode=self.mode,
            n=self.n,
            solver_calls=solver.solver_calls_ - calls_before,
            eigenvalues=_all_eigenvalues(solver, eigenvalues),
            params={"n": self.n},
        )


def _all_eigenvalues(solver: EigenSolver, fallback: np.ndarray) -> np.ndarray:
    found = getattr(solver, "eigenvalues_", None)
    return np.array(found if found is not None else fallback, dtype=np.float64)


def make_cutoff(settings: CutoffSettings) -> AdaptiveCutoff | FixedCutoff:
    """The cutoff that ``settings`` describe."""
    if settings.mode == "fixed":
        return FixedCutoff(settings.n)
    return AdaptiveCutoff(
        xi=settings.xi,
        t=settings.t,
        seed=settings.seed,
        n_min=settings.n_min,
        n_max=settings.n_max,
        margin=settings.margin,
    )
