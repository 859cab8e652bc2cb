"""How many eigenpairs a model gets: the tunable model-adaptive cutoff (Williams & Ilies).

A fixed count captures a different part of the spectrum for every model and sampling. The
adaptive cutoff instead stops where the next eigenpair would change a heat kernel sum by
less than ``xi``. The rule is a function of the spectrum alone (``window_cutoff``)::

    n* = first n with  exp(-t f_n(n-1)) - exp(-t f_n(n)) < xi

where ``f_n`` is the quadratic ``lambda(i) = a + b i + c i^2`` least-squares fitted to the
eigenvalues ``lambda_1 .. lambda_w(n)`` of the window ``w(n) = clip(n + margin, seed, n_max)``
(made non-decreasing), and ``n = clip(n*, n_min, n_max)``. The fit smooths the steps between
near-degenerate eigenvalues (sphere multiplets, sampling noise) that would fake a zero
contribution, and because its window is set by ``n`` itself, not by how many eigenvalues
happen to be computed, the same model always gets the same ``n``.

``AdaptiveCutoff.select`` computes a seed of eigenvalues (or, given a predicted ``n``, goes
straight to ``prediction + 2 margin``: the window of ``n`` reaches ``n + margin``, so this
absorbs a prediction up to ``margin`` too low), evaluates the rule on every ``n`` whose window is
computed, and when ``n*`` lies beyond them asks the solver for more: up to the ``n`` that the
fit of all computed eigenvalues extrapolates, plus ``margin``. On Weyl-like spectra that is
the seed plus one solver call, or a single call when the prediction was right. A wrong
prediction costs calls, never changes ``n``.

The solver is anything with ``solve(count) -> (eigenvalues, eigenvectors)`` and a
``solver_calls_`` counter, such as ``core.eigen.SpectralSolver``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any, Protocol

import numpy as np

from core.settings import CutoffSettings

__all__ = [
    "AdaptiveCutoff",
    "CutoffRecord",
    "CutoffResult",
    "FixedCutoff",
    "contribution_cutoff",
    "make_cutoff",
    "window_cutoff",
]

# Rounds after which the adaptive cutoff gives up refining and clamps; each round grows the
# computed spectrum, so this only guards against a pathological, ever-receding prediction.
_MAX_ROUNDS = 8


class EigenSolver(Protocol):
    solver_calls_: int

    def solve(self, count: int) -> tuple[np.ndarray, np.ndarray]: ...


@dataclass(frozen=True)
class CutoffRecord:
    """What the cutoff decided for one model: the one record of it that the database
    stores (``to_json``), the API and the command line show, and the evaluation keeps.

    Attributes
    ----------
    mode : str
        ``"adaptive"`` or ``"fixed"``.
    n : int
        Eigenpairs used by the signatures.
    solver_calls : int
        Calls to the eigen-solver that computed something (the seed counts as one).
    predicted : list of int
        Unclamped ``n`` extrapolated in each round that had to ask for more (empty for a
        fixed cutoff, or when the first call already decided).
    xi, t, seed, n_min, n_max, margin : float, float, int, int, int, int, or None
        The adaptive cutoff's parameters (``AdaptiveCutoff``); None for a fixed cutoff.
    prediction : int or None
        ``n`` predicted before the solve (``core.cutoff_predictor``), None without one.
    prediction_held : bool or None
        Whether the first call, to ``prediction + 2 margin``, decided ``n`` (None without one).
    features : list of float or None
        The pre-solve features the predictor learns ``n`` from (None when not recorded).
    """

    mode: str
    n: int
    solver_calls: int
    predicted: list[int] = field(default_factory=list)
    xi: float | None = None
    t: float | None = None
    seed: int | None = None
    n_min: int | None = None
    n_max: int | None = None
    margin: int | None = None
    prediction: int | None = None
    prediction_held: bool | None = None
    features: list[float] | None = None

    def to_json(self) -> dict[str, Any]:
        """Plain JSON types only (numpy scalars converted)."""
        return {f.name: _plain(getattr(self, f.name)) for f in fields(CutoffRecord)}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> CutoffRecord:
        """The record ``to_json`` wrote. Records stored before the record had this form kept
        the adaptive parameters under ``params``: they are read too."""
        flat = {**(data.get("params") or {}), **data}
        flat.pop("n", None)  # a fixed cutoff's params held its n: the record's n wins
        known = {f.name for f in fields(CutoffRecord)}
        return cls(n=int(data["n"]), **{k: v for k, v in flat.items() if k in known})


@dataclass(frozen=True)
class CutoffResult(CutoffRecord):
    """A cutoff's record with every eigenvalue the solve computed.

    Attributes
    ----------
    eigenvalues : (m,) float
        Every eigenvalue computed, ``m >= n``.
    """

    eigenvalues: np.ndarray = field(default_factory=lambda: np.empty(0))

    def record(self, features: np.ndarray | None = None) -> CutoffRecord:
        """The record to keep, with the predictor's pre-solve ``features : (f,) float``."""
        kept = {f.name: getattr(self, f.name) for f in fields(CutoffRecord)}
        if features is not None:
            kept["features"] = [float(v) for v in np.asarray(features).ravel()]
        return CutoffRecord(**kept)


def _plain(value: Any) -> Any:
    """A JSON-ready copy of a value that may hold numpy scalars or arrays."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(item) for item in value]
    return value


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
        """Unclamped n extrapolated from the fit of all ``eigenvalues`` (4 n_max if beyond)."""
        horizon = 4 * self.n_max
        predicted = _quadratic_prediction(np.asarray(eigenvalues, dtype=np.float64), horizon)
        n = contribution_cutoff(predicted, self.xi, self.t)
        return horizon if n is None else n

    def decide(self, eigenvalues: np.ndarray, complete: bool = False) -> int | None:
        """``n`` by the rule, or None when the computed ``eigenvalues`` do not decide it yet.

        ``complete`` says there are no more eigenvalues (the whole spectrum is computed).
        """
        return window_cutoff(
            eigenvalues,
            self.xi,
            self.t,
            seed=self.seed,
            margin=self.margin,
            n_min=self.n_min,
            n_max=self.n_max,
            complete=complete,
        )

    def select(self, solver: EigenSolver, prediction: int | None = None) -> CutoffResult:
        """Run the cutoff on ``solver``; the solver keeps every eigenpair it computed.

        Parameters
        ----------
        solver : EigenSolver
        prediction : int, optional
            ``n`` expected for this model (``core.cutoff_predictor``): the first call asks
            for ``prediction + 2 margin`` instead of the seed. It changes the calls, not ``n``.
        """
        calls_before = solver.solver_calls_
        first = self.seed
        if prediction is not None:
            # Deciding n needs its window, up to n + margin: one more margin absorbs a
            # prediction that is up to margin too low (measured: most misses were).
            first = int(np.clip(int(prediction) + 2 * self.margin, self.seed, self.n_max))
        eigenvalues, complete = self._solve(solver, first)
        predictions: list[int] = []
        n = self.decide(eigenvalues, complete)
        for _ in range(_MAX_ROUNDS):
            if n is not None:
                break
            predicted = self.predict(eigenvalues)
            predictions.append(predicted)
            # Enough for the window of the extrapolated n, and always progress.
            wanted = max(predicted + self.margin, eigenvalues.size + self.margin + 1)
            eigenvalues, complete = self._solve(solver, min(wanted, self.n_max))
            n = self.decide(eigenvalues, complete)
        if n is None:  # a pathological, ever-receding spectrum: the clamp decides
            n = self.n_max
        eigenvalues, _ = solver.solve(n)  # no work unless n_min asks for more
        calls = solver.solver_calls_ - calls_before
        return CutoffResult(
            mode=self.mode,
            n=n,
            solver_calls=calls,
            predicted=predictions,
            eigenvalues=_all_eigenvalues(solver, eigenvalues),
            **self.params(),
            prediction=None if prediction is None else int(prediction),
            prediction_held=None if prediction is None else calls == 1,
        )

    @staticmethod
    def _solve(solver: EigenSolver, count: int) -> tuple[np.ndarray, bool]:
        """All eigenvalues computed after asking for ``count``; True if that is all there are."""
        solved, _ = solver.solve(count)
        # Every eigenvalue the solver found counts, including any a band found beyond the
        # count asked for: the rule's windows may use them at no cost.
        return _all_eigenvalues(solver, solved), len(solved) < count


def window_cutoff(
    eigenvalues: np.ndarray,
    xi: float,
    t: float,
    *,
    seed: int,
    margin: int,
    n_min: int,
    n_max: int,
    complete: bool = False,
) -> int | None:
    """The adaptive rule (module docstring) on the first eigenvalues of a spectrum.

    Parameters
    ----------
    eigenvalues : (m,) float
        The smallest ``m`` eigenvalues, ascending.
    xi, t, seed, margin, n_min, n_max
        As in ``AdaptiveCutoff``.
    complete : bool
        The spectrum has no more eigenvalues (windows are cut at ``m``).

    Returns
    -------
    n : int or None
        ``clip(n*, n_min, n_max)``, or None when ``n*`` lies beyond every ``n`` whose window
        ``eigenvalues`` covers (more eigenvalues are needed to decide).
    """
    values = np.asarray(eigenvalues, dtype=np.float64)
    size = values.size
    limit = min(n_max, size) if complete else n_max
    candidates = np.arange(2, limit + 1)
    windows = np.clip(candidates + margin, seed, n_max)
    if complete:
        windows = np.minimum(windows, size)
    covered = windows <= size
    # Windows grow with n, so the covered candidates are a prefix; past it, undecided.
    checkable = int(np.count_nonzero(covered))
    candidates, windows = candidates[:checkable], windows[:checkable]
    usable = windows >= 3  # a quadratic needs three eigenvalues
    steps = _windowed_steps(values, candidates[usable], windows[usable], t)
    below = np.flatnonzero(steps < xi)
    if below.size:
        return int(np.clip(candidates[usable][below[0]], n_min, n_max))
    if checkable < limit - 1:
        return None  # n* lies beyond the computed windows: more eigenvalues are needed
    return int(np.clip(max(limit, 2), n_min, n_max))


def _windowed_steps(
    values: np.ndarray, candidates: np.ndarray, windows: np.ndarray, t: float
) -> np.ndarray:
    """``exp(-t f(n-1)) - exp(-t f(n))`` for each candidate n, f fitted on ``values[:w(n)]``.

    All the least-squares quadratics at once from cumulative sums (normal equations in the
    scaled index i / w, well conditioned); f is made non-decreasing, as in
    ``_quadratic_prediction``, by its running maximum over 1..n.
    """
    if candidates.size == 0:
        return np.empty(0)
    index = np.arange(1, values.size + 1, dtype=np.float64)
    powers = np.stack([np.cumsum(index**k) for k in range(5)])  # sum i^k, k = 0..4
    moments = np.stack([np.cumsum(values * index**k) for k in range(3)])  # sum lambda i^k
    last = windows - 1
    scale = windows.astype(np.float64)
    gram = np.empty((windows.size, 3, 3))
    for row in range(3):
        for col in range(3):
            gram[:, row, col] = powers[row + col, last] / scale ** (row + col)
    rhs = np.stack([moments[k, last] / scale**k for k in range(3)], axis=1)
    coefficients = np.linalg.solve(gram, rhs[..., None])[..., 0]  # (a, b, c) in x = i / w

    def fit(at: np.ndarray) -> np.ndarray:
        x = at / scale
        return coefficients[:, 0] + coefficients[:, 1] * x + coefficients[:, 2] * x**2

    # Running maximum over the integers 1..n - 1: the ends, or the vertex of a concave fit.
    previous = candidates.astype(np.float64) - 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = -coefficients[:, 1] * scale / (2.0 * coefficients[:, 2])
    vertex = np.where(np.isfinite(vertex), vertex, 1.0)
    peak = np.maximum(fit(np.ones_like(previous)), fit(previous))
    for rounded in (np.floor(vertex), np.ceil(vertex)):
        peak = np.maximum(peak, fit(np.clip(rounded, 1.0, previous)))
    current = np.maximum(peak, fit(previous + 1.0))
    return np.exp(-t * peak) - np.exp(-t * current)


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
