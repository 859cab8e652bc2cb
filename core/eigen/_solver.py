"""``SpectralSolver``: smallest eigenpairs of L phi = lambda M phi, band by band, incrementally.

Each band is one shift-invert Lanczos call (ARPACK through ``scipy.sparse.linalg.eigsh``) on a
factorisation of L - s M computed once per shift and cached; the same factorisation gives,
by Sylvester's law of inertia, the exact number of eigenvalues below s, which must equal
the number found (see ``_factor``). Bands are placed along the spectrum from the mean gap
of the eigenvalues found so far (Weyl's law: about constant), and the eigenpairs already
found are kept, so asking for more later only computes the new ones. Small band sizes keep
ARPACK's orthogonalisation cost, which grows faster than linearly with k, in check.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from scipy.sparse.linalg import ArpackError, ArpackNoConvergence, LinearOperator, eigsh

from core.eigen._banded import (
    SHIFT_FRACTION,
    BandSplit,
    band_request,
    mean_gap,
    next_shift,
    split_band,
)
from core.eigen._factor import ShiftFactorisation, factorise_shifted
from core.eigen._threads import pin_blas_threads
from core.errors import SolverError

__all__ = ["BandRecord", "SpectralSolver", "default_shift", "smallest_eigenpairs"]

# Below this size (or when more than half the spectrum is asked for) a dense generalized
# eigen-decomposition of all n eigenpairs is cheaper and simpler than Lanczos.
_DENSE_SIZE = 300
# Tries per band: a retry follows a missed gap (shift moved down), a band that was one tied
# cluster (more eigenpairs asked) or a factorisation too close to an eigenvalue (shift nudged).
_MAX_ATTEMPTS = 8
# The first shift, below the zero eigenvalue(s) of the PSD stiffness, in units of the Weyl
# gap 4 pi / area: far enough for a well-conditioned factorisation, close enough that the
# lowest eigenvalues are the best separated after inversion.
_FIRST_SHIFT = -1e-3
# Extra eigenpairs asked when a band is widened after a miss.
_EXTRA = 4
# Nudge of a shift that hit an eigenvalue, in units of the local mean gap.
_NUDGE = 1e-3
# Lanczos basis size of a band, in units of the eigenpairs asked: ARPACK's default (2k + 1)
# spends more on orthogonalising the basis than the extra vectors save in restarts; 1.5k was
# about 20 % faster at 3000 points (three parts). Exactness is
# unchanged: ARPACK still converges to tol=0 and the inertia count certifies the band.
_BASIS_FACTOR = 1.5


@dataclass(frozen=True)
class BandRecord:
    """What one band computed.

    Attributes
    ----------
    shift : float
        Final shift of the band (nan for the dense path).
    count : int
        Eigenpairs the band added.
    seconds : float
        Wall time of the band, factorisations included.
    requested : int
        Eigenpairs asked of the last Lanczos call.
    attempts : int
        Lanczos calls the band needed (1 unless a retry was required).
    factor_seconds : float
        Time spent in new factorisations.
    inertia : int or None
        Eigenvalues below the shift by Sylvester's law (None: not available, check skipped).
    upper : float
        Every eigenvalue below it is known after this band.
    """

    shift: float
    count: int
    seconds: float
    requested: int = 0
    attempts: int = 1
    factor_seconds: float = 0.0
    inertia: int | None = None
    upper: float = float("nan")


def weyl_gap(mass: sp.spmatrix) -> float:
    """Mean eigenvalue spacing predicted by Weyl's law for a surface, 4 pi / area."""
    return 4.0 * np.pi / float(mass.diagonal().sum())


def default_shift(mass: sp.spmatrix) -> float:
    """A shift just below the spectrum of a PSD stiffness, ``_FIRST_SHIFT`` Weyl gaps."""
    return _FIRST_SHIFT * weyl_gap(mass)


def _start_vector(size: int, seed: int) -> np.ndarray:
    """Deterministic ARPACK start vector, so results repeat run to run."""
    return np.random.default_rng(seed).standard_normal(size)


def _m_normalised(vectors: np.ndarray, mass: sp.spmatrix) -> np.ndarray:
    """Scale each column to phi^T M phi = 1."""
    norms = np.sqrt(np.einsum("ij,ij->j", vectors, mass @ vectors))
    return vectors / norms


def _orthogonal_to(vectors: np.ndarray, known: np.ndarray, mass: sp.spmatrix) -> np.ndarray:
    """``vectors`` with their M-components along the ``known`` (M-orthonormal) columns
    removed, M-normalised again.

    Each band comes from a Lanczos run of its own at its own shift: its vectors are
    M-orthogonal to earlier bands' only to the accuracy of the shifted solves (2.4e-8 across
    a band edge on the sampled sphere of tests/test_eigen.py, on one machine). One
    projection, the "locking" of multi-shift Lanczos, restores orthogonality to working
    precision (3e-15 there); it moves each vector by no more than that error.
    """
    if known.shape[1] == 0:
        return vectors
    vectors = vectors - known @ (known.T @ (mass @ vectors))
    return _m_normalised(vectors, mass)


def _mass_operator(mass: sp.spmatrix) -> LinearOperator | sp.spmatrix:
    """M as ARPACK applies it: a diagonal ``mass`` as one elementwise product.

    ARPACK asks for ``M x`` about 350 times per band; scipy's sparse product spends some
    15 microseconds of Python around each 3 of work, a tenth of a describe. The product is
    the same number either way (one term per row). A mass that is not diagonal is used as
    given.
    """
    diagonal = np.asarray(mass.diagonal(), dtype=np.float64)
    if mass.nnz != np.count_nonzero(diagonal):
        return mass
    return LinearOperator(
        mass.shape, matvec=lambda vector: diagonal * vector.ravel(), dtype=np.float64
    )


def _lanczos(
    stiffness: sp.spmatrix,
    mass: sp.spmatrix,
    count: int,
    factor: ShiftFactorisation,
    seed: int,
    basis: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` eigenpairs nearest ``factor.shift``, ascending, M-normalised.

    ``basis`` is ARPACK's ``ncv`` (None: its default, 2 count + 1).
    """
    try:
        values, vectors = eigsh(
            stiffness,
            k=count,
            M=_mass_operator(mass),
            sigma=factor.shift,
            which="LM",
            OPinv=factor.inverse_operator(),
            v0=_start_vector(stiffness.shape[0], seed),
            ncv=basis,
            tol=0.0,
        )
    except (ArpackNoConvergence, ArpackError) as error:
        raise SolverError(f"Lanczos at shift {factor.shift:.6g} failed: {error}") from error
    if not (np.all(np.isfinite(values)) and np.all(np.isfinite(vectors))):
        raise SolverError(f"Lanczos at shift {factor.shift:.6g} returned non-finite values")
    order = np.argsort(values)
    return values[order], _m_normalised(vectors[:, order], mass)


def smallest_eigenpairs(
    stiffness: sp.spmatrix, mass: sp.spmatrix, count: int, *, shift: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Reference: the ``count`` smallest eigenpairs in one shift-invert Lanczos call.

    Parameters
    ----------
    stiffness, mass : (n, n) sparse
        L (symmetric PSD) and M (diagonal positive).
    count : int
        Eigenpairs wanted (< n).
    shift : float, optional
        Shift below the spectrum; default ``default_shift(mass)``.

    Returns
    -------
    eigenvalues : (count,) float
        Ascending.
    eigenvectors : (n, count) float
        M-orthonormal columns.
    """
    shift = default_shift(mass) if shift is None else float(shift)
    with pin_blas_threads():
        factor = factorise_shifted(stiffness, mass, shift)
        return _lanczos(stiffness, mass, int(count), factor, seed=0)


@dataclass
class _BandAttempt:
    """Mutable state of one band while it retries."""

    shift: float
    requested: int
    attempts: int = 0
    factor_seconds: float = 0.0
    factor: ShiftFactorisation | None = None
    split: BandSplit | None = None
    values: np.ndarray | None = None
    vectors: np.ndarray | None = None

    def done(self, lower: float) -> bool:
        return self.split is not None and self.split.progressed(lower)


class SpectralSolver:
    """Smallest eigenpairs of L phi = lambda M phi, phi^T M phi = 1, computed incrementally.

    Parameters
    ----------
    stiffness : (n, n) sparse
        L, symmetric positive semi-definite.
    mass : (n, n) sparse
        M, diagonal positive.
    band_size : int
        Eigenpairs per shift-invert Lanczos call.
    shift : float, optional
        First shift, below the spectrum (negative); default ``default_shift(mass)``.

    Attributes
    ----------
    eigenvalues_ : (m,) float
        Every eigenvalue found so far, ascending (read-only).
    eigenvectors_ : (n, m) float
        Their M-orthonormal eigenvectors (read-only).
    solver_calls_ : int
        ``solve`` calls that computed something.
    factorisations_ : int
        Sparse factorisations computed (one per distinct shift).
    bands_ : list of BandRecord
        One record per band.

    The counters read 0 (and ``bands_`` empty) before the first ``solve``, so that callers
    such as ``core.cutoff`` can take differences around their calls.
    """

    solver_calls_: int = 0
    factorisations_: int = 0
    bands_: Sequence[BandRecord] = ()  # a list from the first solve on

    def __init__(
        self,
        stiffness: sp.spmatrix,
        mass: sp.spmatrix,
        *,
        band_size: int = 50,
        shift: float | None = None,
    ) -> None:
        self.stiffness = stiffness
        self.mass = mass
        self.band_size = band_size
        self.shift = shift

    # -- public -----------------------------------------------------------------------------

    def solve(self, count: int) -> tuple[np.ndarray, np.ndarray]:
        """The ``count`` smallest eigenpairs, continuing from those already found.

        Parameters
        ----------
        count : int
            Eigenpairs wanted; at most n are returned.

        Returns
        -------
        eigenvalues : (count,) float
            Ascending (read-only view).
        eigenvectors : (n, count) float
            M-orthonormal columns (read-only view).

        Raises
        ------
        core.errors.SolverError
            A factorisation or Lanczos call failed, or the inertia count disagrees with the
            eigenvalues found (an eigenvalue was missed).
        """
        if count < 1:
            raise ValueError(f"count must be at least 1, not {count}")
        if not hasattr(self, "eigenvalues_"):
            self._start()
        target = min(int(count), self._size)
        if self.eigenvalues_.size < target:
            self.solver_calls_ += 1
            with pin_blas_threads():
                if self._size <= _DENSE_SIZE or target > self._size // 2:
                    self._solve_dense()
                while self.eigenvalues_.size < target:
                    self._solve_band(target - self.eigenvalues_.size)
        return self.eigenvalues_[:target], self.eigenvectors_[:, :target]

    # -- state ------------------------------------------------------------------------------

    def _start(self) -> None:
        """Validate the inputs and create the empty state (first ``solve`` only)."""
        self._size = int(self.stiffness.shape[0])
        if self.stiffness.shape != (self._size, self._size) or self.mass.shape != (
            self._size,
            self._size,
        ):
            raise ValueError("stiffness and mass must be square and of the same size")
        if self.band_size < 2:
            raise ValueError(f"band_size must be at least 2, not {self.band_size}")
        first_shift = default_shift(self.mass) if self.shift is None else float(self.shift)
        if not first_shift < 0:
            raise ValueError(f"the first shift must be negative, below the spectrum: {first_shift}")
        self._first_shift = first_shift
        self._weyl_gap = weyl_gap(self.mass)
        self._lower = float("-inf")  # every eigenvalue below it is known
        self._factors: dict[float, ShiftFactorisation] = {}
        self._store(np.empty(0), np.empty((self._size, 0)))
        self.solver_calls_ = 0
        self.factorisations_ = 0
        self._bands: list[BandRecord] = []
        self.bands_ = self._bands

    def _store(self, eigenvalues: np.ndarray, eigenvectors: np.ndarray) -> None:
        eigenvalues.flags.writeable = False
        eigenvectors.flags.writeable = False
        self.eigenvalues_ = eigenvalues
        self.eigenvectors_ = eigenvectors

    def _factorisation(self, shift: float) -> tuple[ShiftFactorisation, float]:
        """Cached factorisation of L - shift M, and the seconds spent on it now (0 if cached)."""
        if shift in self._factors:
            return self._factors[shift], 0.0
        factor = factorise_shifted(self.stiffness, self.mass, shift)
        self._factors[shift] = factor
        self.factorisations_ += 1
        return factor, factor.seconds

    # -- solving ----------------------------------------------------------------------------

    def _solve_dense(self) -> None:
        """All n eigenpairs at once (small problems, or most of the spectrum asked for)."""
        start = time.perf_counter()
        try:
            values, vectors = scipy.linalg.eigh(self.stiffness.toarray(), self.mass.toarray())
        except (np.linalg.LinAlgError, ValueError) as error:
            raise SolverError(f"dense eigen-decomposition failed: {error}") from error
        if not (np.all(np.isfinite(values)) and np.all(np.isfinite(vectors))):
            raise SolverError("dense eigen-decomposition returned non-finite values")
        self._store(values, _m_normalised(vectors, self.mass))
        self._lower = float("inf")
        self._bands.append(
            BandRecord(shift=float("nan"), count=values.size, seconds=time.perf_counter() - start)
        )

    def _solve_band(self, needed: int) -> None:
        """One band: at least one new eigenpair above the bound, certified complete."""
        start = time.perf_counter()
        known = self.eigenvalues_
        requested = band_request(needed, self.band_size, self._size)
        if known.size == 0:
            shift = self._first_shift
            lower = shift  # PSD: nothing below a negative shift (checked by inertia)
        else:
            lower = self._lower
            gap = mean_gap(known, self._weyl_gap)
            shift = next_shift(lower, requested, gap)
        attempt = _BandAttempt(shift=shift, requested=requested)
        while not attempt.done(lower):
            self._attempt_band(attempt, lower)
        factor, split = attempt.factor, attempt.split
        # done() holds only after an attempt that set all four.
        assert factor is not None and split is not None
        assert attempt.values is not None and attempt.vectors is not None
        new_values = attempt.values[split.start : split.stop]
        new_vectors = _orthogonal_to(
            attempt.vectors[:, split.start : split.stop], self.eigenvectors_, self.mass
        )
        self._check_inertia(factor, known.size + int(np.count_nonzero(new_values < factor.shift)))
        self._store(
            np.concatenate([known, new_values]), np.hstack([self.eigenvectors_, new_vectors])
        )
        self._lower = split.new_lower
        # Later shifts all lie above the bound, so factorisations below it are never used
        # again; at 50k points each holds tens of MB.
        self._factors = {shift: f for shift, f in self._factors.items() if shift > self._lower}
        self._bands.append(
            BandRecord(
                shift=factor.shift,
                count=int(new_values.size),
                seconds=time.perf_counter() - start,
                requested=attempt.requested,
                attempts=attempt.attempts,
                factor_seconds=attempt.factor_seconds,
                inertia=factor.inertia,
                upper=split.new_lower,
            )
        )

    def _attempt_band(self, attempt: _BandAttempt, lower: float) -> None:
        """One Lanczos call for a band; adjusts shift or size in ``attempt`` for a retry."""
        attempt.attempts += 1
        if attempt.attempts > _MAX_ATTEMPTS:
            raise SolverError(
                f"band near shift {attempt.shift:.6g} found no new eigenvalues after "
                f"{_MAX_ATTEMPTS} attempts"
            )
        try:
            factor, seconds = self._factorisation(attempt.shift)
        except SolverError:
            # The shift sits on an eigenvalue (K singular to working precision): nudge it.
            attempt.shift += _NUDGE * mean_gap(self.eigenvalues_, self._weyl_gap)
            return
        attempt.factor_seconds += seconds
        requested = attempt.requested
        # Never above ARPACK's default (2k + 1, at least 20): small bands keep it.
        basis = max(int(_BASIS_FACTOR * requested) + 1, requested + 20)
        basis = min(self._size - 1, basis, max(2 * requested + 1, 20))
        values, vectors = _lanczos(
            self.stiffness, self.mass, requested, factor, seed=len(self.bands_), basis=basis
        )
        # Inertia counts the eigenvalues below s: the known ones plus those in [lower, s). If
        # the band holds all of the latter, no eigenvalue hides between bound and window.
        new_below = (values >= lower) & (values < attempt.shift)
        found_below = self.eigenvalues_.size + int(np.count_nonzero(new_below))
        gap_certified = factor.inertia is not None and factor.inertia == found_below
        split = split_band(values, attempt.shift, lower, gap_certified=gap_certified)
        attempt.factor, attempt.split, attempt.values, attempt.vectors = (
            factor,
            split,
            values,
            vectors,
        )
        if split.missed_gap:
            missing = None if factor.inertia is None else factor.inertia - found_below
            if missing is not None and attempt.requested + missing <= 2 * self.band_size:
                # Inertia says how many eigenvalues the window missed below it: widen the
                # band by that many at the same shift (no new factorisation).
                attempt.requested = min(attempt.requested + missing + _EXTRA, self._size - 2)
            else:
                # The band is denser than estimated: its own width gives a better density.
                attempt.shift = lower + SHIFT_FRACTION * split.radius
        elif not split.progressed(lower):
            # The whole band above the bound is one tied cluster: widen it.
            if attempt.requested >= self._size - 2:
                raise SolverError(f"no eigenvalue above {lower:.6g} could be certified")
            attempt.requested = min(2 * attempt.requested, self._size - 2)

    @staticmethod
    def _check_inertia(factor: ShiftFactorisation, found_below: int) -> None:
        """Sylvester's count of eigenvalues below the shift must match what was found."""
        if factor.inertia is not None and factor.inertia != found_below:
            raise SolverError(
                f"inertia check failed at shift {factor.shift:.6g}: {factor.inertia} eigenvalues "
                f"lie below it but {found_below} were found"
            )
