"""Describe every model once per sampling and score every variant on it.

A *sampling* is what the expensive stages depend on: the file, the Laplacian, the point
count, the sampling seed, the random rotation and the scan simulation (clean, single view,
multi view). For each sampling we run the service's own stages (``core.pipeline``)::

    load_points -> seeded rotation [-> scan] -> normalised_operators -> SpectralSolver

and keep the eigenpairs in an ``EigenStore``. Every variant on that sampling runs its own
cutoff against a ``VariantSolver``, a view of the store that serves ``solve(count)`` from the
pairs already computed and only asks the real solver for more when the variant needs more.
The view counts solver calls as a solver of its own would (a call that needs nothing new is
free), so each variant's cutoff statistics are what the service would have produced.

Stores are cached as ``.npz`` under ``OUT/cache``, keyed by the file's SHA-256 and the
sampling parameters, so a re-run resumes where the last one stopped.

Eigen-solve seconds per variant are *estimated* from the per-band timings of the solver
(``SpectralSolver.bands_``): the sum of the bands a solver would have computed to reach the
variant's largest request. ``time_variants_directly`` measures the same thing with a fresh
solver per variant on a subset, to check the estimate.
"""

from __future__ import annotations

import hashlib
import re
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from core.cutoff import CutoffRecord, CutoffResult, make_cutoff
from core.evaluation.dataset import Model
from core.evaluation.feature_sampling import FEATURE_OVERSAMPLING, feature_weighted_subsample
from core.evaluation.revolution import fit_axis
from core.evaluation.revolution import revolve as revolve_about
from core.evaluation.scans import random_rotation, scan_of_kind
from core.io import OUTLIER_RATIO, denoise_points, load_points, validate_points
from core.pipeline import descriptor_from_eigenpairs, normalised_operators
from core.settings import EngineSettings

__all__ = [
    "EigenStore",
    "ModelResult",
    "Sampling",
    "VariantSolver",
    "describe_sampling",
    "run_variants",
    "sampling_of",
    "time_variants_directly",
]

#: Clean models are sampled with the variant's point count; a scan is taken of a sample this
#: many times denser and then thinned by the loader's own rule, like an uploaded scan.
SCAN_OVERSAMPLING = 3
#: Cache layout generation: bump when what is cached changes meaning.
_CACHE_VERSION = "e2"  # e2: "+sor" is the median-spacing outlier rule


@dataclass(frozen=True)
class Sampling:
    """Everything the Laplacian and the eigenpairs of one model depend on."""

    laplacian: str
    max_points: int
    sample_seed: int
    rotation_seed: int
    scan: str = "clean"  # "clean" or a scans.SCAN_KINDS kind, optionally with "+sor"
    # Clean samples only: 0 is uniform, above 0 feature-aware (core.evaluation.feature_sampling).
    feature_share: float = 0.0

    def cache_name(self, sha256: str) -> str:
        feature = f"_f{self.feature_share:g}" if self.feature_share else ""
        return (
            f"{sha256[:24]}_{self.laplacian}_p{self.max_points}_s{self.sample_seed}"
            f"_r{self.rotation_seed}_{self.scan}{feature}_{_CACHE_VERSION}.npz"
        )


def sampling_of(settings: EngineSettings, rotation_seed: int, scan: str = "clean",
                feature_share: float = 0.0) -> Sampling:
    """The sampling a variant's settings ask for."""
    if feature_share and scan != "clean":
        raise ValueError("feature-aware sampling is measured on clean samples only")
    return Sampling(
        laplacian=settings.laplacian,
        max_points=settings.max_points,
        sample_seed=settings.sample_seed,
        rotation_seed=rotation_seed,
        scan=scan,
        feature_share=feature_share,
    )


def _model_seed(sha256: str, *salt: object) -> int:
    """A 63-bit seed from the file's content and a salt: stable across runs and machines."""
    text = "|".join([sha256, *map(str, salt)])
    return int(hashlib.sha256(text.encode()).hexdigest()[:15], 16)


def _band_table(solver: Any) -> list[tuple[int, float]]:
    """``(eigenpairs available after the band, seconds of the band)`` from ``bands_``.

    Accepts dict or attribute records; the fields looked for are the end index of the band
    (``stop``/``end``/``count``/``total``) and its ``seconds``.
    """
    table: list[tuple[int, float]] = []
    for band in getattr(solver, "bands_", []) or []:
        record: dict[str, Any] = band if isinstance(band, dict) else vars(band)
        seconds = float(record.get("seconds", record.get("time", 0.0)))
        end = None
        for key in ("total", "stop", "end", "count_after", "n_total"):
            if key in record:
                end = int(record[key])
                break
        if end is None:
            end = (table[-1][0] if table else 0) + int(record.get("count", 0))
        table.append((end, seconds))
    return table


@dataclass
class EigenStore:
    """The operators' eigenpairs of one sampling, grown on demand.

    Attributes
    ----------
    eigenvalues : (m,) float
    eigenvectors : (n, m) float
    areas : (n,) float
        Diagonal of the unit-area mass matrix.
    bands : list of (int, float)
        ``(pairs available after the band, seconds)``, in order of computation.
    timings : dict
        ``load``, ``laplacian`` seconds and ``n_points``.
    factory : callable, optional
        Builds the real solver (rebuilding the Laplacian when the store came from cache).
    points : (n, 3) float, optional
        The points of the operators, for the descriptor's extrinsic blocks.
    """

    eigenvalues: np.ndarray
    eigenvectors: np.ndarray
    areas: np.ndarray
    bands: list[tuple[int, float]]
    timings: dict[str, float]
    factory: Callable[[], Any] | None = None
    points: np.ndarray | None = None
    changed: bool = False
    _solver: Any = None

    @property
    def count(self) -> int:
        return int(self.eigenvalues.size)

    def ensure(self, count: int) -> None:
        """Make at least ``count`` eigenpairs available (as many as exist if fewer)."""
        if count <= self.count:
            return
        if self._solver is None:
            if self.factory is None:
                raise RuntimeError("eigen store needs more pairs but has no solver")
            self._solver = self.factory()
            # A fresh solver starts from zero: its band timings replace the cached ones.
            self.bands = []
        values, vectors = self._solver.solve(count)
        found = np.asarray(getattr(self._solver, "eigenvalues_", values))
        vectors_all = getattr(self._solver, "eigenvectors_", None)
        if vectors_all is not None and len(found) >= len(values):
            values, vectors = found, np.asarray(vectors_all)
        self.eigenvalues = np.asarray(values, dtype=np.float64)
        self.eigenvectors = np.asarray(vectors, dtype=np.float64)
        self.bands = _band_table(self._solver) or [(self.count, float("nan"))]
        self.changed = True

    def seconds_for(self, count: int) -> float:
        """Eigen-solve seconds a solver of its own would have spent to reach ``count``."""
        total = 0.0
        reached = 0
        for end, seconds in self.bands:
            if reached >= count:
                break
            total += seconds
            reached = end
        return total

    def save(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_suffix(".part.npz")
        extra = {} if self.points is None else {"points": self.points}
        np.savez(
            partial,
            **extra,  # type: ignore[arg-type]  # numpy's stubs: ** could fill allow_pickle
            eigenvalues=self.eigenvalues,
            eigenvectors=self.eigenvectors,
            areas=self.areas,
            bands=np.asarray(self.bands, dtype=np.float64).reshape(-1, 2),
            timings=np.asarray([[k, v] for k, v in self.timings.items()], dtype=object),
        )
        partial.replace(path)  # atomic: an interrupted run never leaves a half cache file
        self.changed = False

    @classmethod
    def load(cls, path: Path, factory: Callable[[], Any] | None) -> EigenStore:
        with np.load(path, allow_pickle=True) as data:
            bands = [(int(end), float(sec)) for end, sec in data["bands"]]
            return cls(
                eigenvalues=data["eigenvalues"],
                eigenvectors=data["eigenvectors"],
                areas=data["areas"],
                bands=bands,
                timings={str(k): float(v) for k, v in data["timings"]},
                factory=factory,
                # Caches written before the extrinsic blocks have no points.
                points=data["points"] if "points" in data.files else None,
            )


class VariantSolver:
    """What one variant's cutoff sees: a solver of its own, backed by the shared store.

    ``solve(count)`` counts as a solver call only when ``count`` exceeds what this view has
    already handed out, as a real incremental solver would.
    """

    def __init__(self, store: EigenStore) -> None:
        self.store = store
        self.served = 0
        self.solver_calls_ = 0

    @property
    def eigenvalues_(self) -> np.ndarray:
        return self.store.eigenvalues[: self.served]

    def solve(self, count: int) -> tuple[np.ndarray, np.ndarray]:
        if count > self.served:
            self.store.ensure(count)
            self.solver_calls_ += 1
            self.served = min(count, self.store.count)
        return self.store.eigenvalues[:count], self.store.eigenvectors[:, :count]


def _cleanup_steps(steps: str) -> tuple[bool, tuple[str, int, int] | None, float | None, bool]:
    """Parse the cleanup suffix of a scan kind: ``sor`` (the engine's outlier filter),
    ``mor<ratio>`` (the same filter with that ratio), ``<fit><k>[x<passes>]`` (denoise) and
    ``rev`` (complete the scan by turning it about its fitted axis,
    ``core.evaluation.revolution``).

    ``"sor+plane16x2"`` -> (True, ("plane", 16, 2), None, False); ``""`` -> (False, None,
    None, False).
    """
    outliers, denoise, ratio, revolve = False, None, None, False
    for step in filter(None, steps.split("+")):
        if step == "sor":
            outliers = True
            continue
        if step == "rev":
            revolve = True
            continue
        if re.fullmatch(r"mor\d+(\.\d+)?", step):
            ratio = float(step[3:])
            continue
        match = re.fullmatch(r"(plane|quadric)(\d+)(?:x(\d+))?", step)
        if match is None:
            raise ValueError(f"unknown scan cleanup step {step!r}")
        denoise = (match[1], int(match[2]), int(match[3] or 1))
    return outliers, denoise, ratio, revolve


def _sample_points(model: Model, sampling: Sampling, min_points: int) -> tuple[np.ndarray, float]:
    """Load, rotate and (for scans) scan one model; returns points and load seconds.

    Scan kind ``points`` is no scan at all: the clean sample handed over as a point cloud (an
    uploaded ``.xyz``), so that it goes through the point-cloud cleanup steps.
    """
    start = time.perf_counter()
    dense = sampling.max_points * (1 if sampling.scan == "clean" else SCAN_OVERSAMPLING)
    kind, _, steps = sampling.scan.partition("+")
    if kind == "points":
        dense = sampling.max_points
    if sampling.feature_share:
        dense = sampling.max_points * FEATURE_OVERSAMPLING
    shape = load_points(
        str(model.path), max_points=dense, min_points=min_points, seed=sampling.sample_seed
    )
    seed = _model_seed(model.sha256, sampling.rotation_seed)
    points = shape.points @ random_rotation(np.random.default_rng(seed)).T
    if sampling.feature_share:
        points = points[feature_weighted_subsample(
            points, sampling.max_points, sampling.feature_share, sampling.sample_seed)]
    if sampling.scan != "clean":
        outliers, denoise, ratio, revolve = _cleanup_steps(steps)
        # Seeded without the denoise and revolve steps: a denoised or completed scan is the
        # same scan, cleaned, so that with and without them compare paired.
        seed_key = kind + ("+sor" if outliers or ratio is not None else "")
        scan_seed = _model_seed(model.sha256, sampling.rotation_seed, seed_key)
        rng = np.random.default_rng(scan_seed)
        scanned = points if kind == "points" else scan_of_kind(points, rng, kind)
        # The loader's own checks and even thinning, as for an uploaded scan; "+sor" scans go
        # through the engine's outlier filter (EngineSettings.outlier_filter, on by default),
        # plain ones without it, to show what the filter is worth; a denoise step after it.
        points = validate_points(
            scanned, max_points=sampling.max_points, min_points=min_points,
            seed=sampling.sample_seed, remove_outliers=outliers or ratio is not None,
            outlier_ratio=OUTLIER_RATIO if ratio is None else ratio,
        )
        if denoise is not None:
            fit, neighbours, passes = denoise
            points = denoise_points(points, neighbours, passes, fit)
        if revolve:
            points = revolve_about(points, fit_axis(points), len(points), sampling.sample_seed)
    return points, time.perf_counter() - start


def describe_sampling(
    model: Model,
    sampling: Sampling,
    settings: EngineSettings,
    cache_dir: Path | None,
    solver_factory: Callable[[sp.spmatrix, sp.spmatrix], Any],
) -> EigenStore:
    """The eigen store of one model under one sampling, from cache or computed lazily.

    The Laplacian is built now; eigenpairs are computed when a variant asks for them.
    """
    path = cache_dir / sampling.cache_name(model.sha256) if cache_dir else None
    operators: dict[str, Any] = {}

    def build() -> tuple[sp.spmatrix, sp.spmatrix, dict[str, float]]:
        if not operators:
            points, load_seconds = _sample_points(model, sampling, settings.min_points)
            start = time.perf_counter()
            normalised, stiffness, mass = normalised_operators(points, settings)
            operators.update(
                points=normalised,
                stiffness=stiffness,
                mass=mass,
                timings={
                    "load": load_seconds,
                    "laplacian": time.perf_counter() - start,
                    "n_points": float(points.shape[0]),
                },
            )
        return operators["stiffness"], operators["mass"], operators["timings"]

    def factory() -> Any:
        stiffness, mass, _ = build()
        return solver_factory(stiffness, mass)

    if path is not None and path.exists():
        try:
            store = EigenStore.load(path, factory)
        except (OSError, ValueError, KeyError) as error:
            print(f"  cache {path.name} unreadable ({error}); recomputing", file=sys.stderr)
        else:
            if store.points is None:
                # An older cache: the same seeded sampling again, without the Laplacian. Not
                # normalised, which the extrinsic blocks do not see (position and scale free).
                store.points, _ = _sample_points(model, sampling, settings.min_points)
                store.changed = True
            return store
    stiffness, mass, timings = build()
    return EigenStore(
        eigenvalues=np.empty(0),
        eigenvectors=np.empty((mass.shape[0], 0)),
        areas=np.asarray(mass.diagonal(), dtype=np.float64),
        bands=[],
        timings=dict(timings),
        factory=factory,
        points=operators["points"],
    )


@dataclass
class ModelResult:
    """One variant on one model (or one scan of it)."""

    cutoff: CutoffRecord
    eigensolve_seconds: float
    descriptor_seconds: float
    descriptor: np.ndarray
    n_points: int
    extra: dict[str, float] = field(default_factory=dict)


def run_variants(
    store: EigenStore, variants: dict[str, EngineSettings]
) -> dict[str, ModelResult]:
    """Every variant's cutoff and descriptor on one stored sampling.

    Variants are run in the given order; a variant that needs more eigenpairs than the store
    holds grows it (and the cache is rewritten by the caller).
    """
    results: dict[str, ModelResult] = {}
    for name, settings in variants.items():
        view = VariantSolver(store)
        cutoff: CutoffResult = make_cutoff(settings.cutoff).select(view)
        eigenvalues, eigenvectors = view.solve(cutoff.n)
        timings: dict[str, float] = {}
        _, descriptor, _ = descriptor_from_eigenpairs(
            eigenvalues, eigenvectors, store.areas, store.points, settings, timings
        )
        results[name] = ModelResult(
            cutoff=cutoff.record(),
            eigensolve_seconds=store.seconds_for(view.served),
            descriptor_seconds=timings.get("signature", 0.0) + timings.get("descriptor", 0.0),
            descriptor=descriptor,
            n_points=int(store.timings.get("n_points", store.areas.size)),
            extra={"front_seconds": store.timings.get("load", 0.0)
                   + store.timings.get("laplacian", 0.0)},
        )
    return results


def time_variants_directly(
    model: Model,
    sampling: Sampling,
    variants: dict[str, EngineSettings],
    solver_factory: Callable[[sp.spmatrix, sp.spmatrix], Any],
) -> dict[str, float]:
    """Eigen-solve seconds of each variant with a fresh solver of its own (no sharing)."""
    settings = next(iter(variants.values()))
    points, _ = _sample_points(model, sampling, settings.min_points)
    _, stiffness, mass = normalised_operators(points, settings)
    seconds: dict[str, float] = {}
    for name, variant in variants.items():
        start = time.perf_counter()
        solver = solver_factory(stiffness, mass)
        cutoff = make_cutoff(variant.cutoff).select(solver)
        solver.solve(cutoff.n)
        seconds[name] = time.perf_counter() - start
    return seconds


def group_by_sampling(
    variants: dict[str, EngineSettings], rotation_seed: int, scan: str = "clean"
) -> dict[Sampling, dict[str, EngineSettings]]:
    """Variants grouped by the sampling they need, in first-seen order."""
    groups: dict[Sampling, dict[str, EngineSettings]] = {}
    for name, settings in variants.items():
        groups.setdefault(sampling_of(settings, rotation_seed, scan), {})[name] = settings
    return groups


def progress(done: int, total: int, started: float, label: str) -> None:
    """One line on stderr: count, elapsed and estimated remaining time."""
    elapsed = time.perf_counter() - started
    remaining = elapsed / done * (total - done) if done else float("nan")
    print(
        f"  [{done}/{total}] {label}  elapsed {elapsed:5.0f}s  left ~{remaining:5.0f}s",
        file=sys.stderr,
        flush=True,
    )
