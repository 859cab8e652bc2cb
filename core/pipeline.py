"""``describe``: one shape file in, one search descriptor out.

    load -> validate -> centre -> Laplacian (L, M) -> unit area -> eigenpairs with the
    cutoff -> signatures -> histogram descriptor (+ extrinsic blocks of the points)

Every stage is timed; the timings travel with the result so the service can store them.

For scan mode (``core.views``) ``describe`` can also give the descriptor with the histogram
areas faded out near an open rim (``scan=True``: how a partial scan is queried), and the
descriptors of ``views`` virtual partial views of the shape, each described like a scan, from
the points already loaded.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from core.cutoff import AdaptiveCutoff, CutoffResult, make_cutoff
from core.cutoff_predictor import CutoffPredictor, shape_features
from core.descriptor import DescriptorSpec
from core.eigen import SpectralSolver, pin_blas_threads
from core.errors import InvalidShapeError, SolverError
from core.io import LoadedShape, load_points
from core.laplacian import build_laplacian
from core.normalise import centre, unit_area_mass, unit_bbox_scale
from core.settings import EngineSettings
from core.size import ShapeSize
from core.views import boundary_weights, virtual_views

__all__ = [
    "Description",
    "describe",
    "describe_points",
    "descriptor_from_eigenpairs",
    "normalised_operators",
    "scan_weights",
]


@dataclass
class Description:
    """What ``describe`` found for one shape.

    Attributes
    ----------
    points : (n, 3) float
        The points used, centred and normalised.
    format : str
        Detected input format (``"stl"``, ``"ply"``, ...; ``"array"`` for raw points).
    cutoff : CutoffResult
        n, solver calls, predicted n per round, all eigenvalues computed.
    eigenvalues : (n_eig,) float
        The eigenvalues used by the signature (the first ``cutoff.n``).
    signature : (n, s) float
        Per-point signature, one column per scale of the descriptor.
    areas : (n,) float
        Area each point stands for (unit total area).
    descriptor : (d,) float32
        Unit-norm search vector.
    descriptor_version : str
        Layout and parameters of ``descriptor``.
    timings : dict
        Seconds per stage.
    features : (f,) float
        Pre-solve features (``core.cutoff_predictor.shape_features``), for cutoff predictors.
    scan_descriptor : (d,) float32 or None
        The descriptor with ``scan_weights`` on the areas (asked for with ``scan=True``).
    views : (v, d) float32
        ``scan_descriptor`` of each virtual view that could be described (``views=K``
        asks for K; a view with fewer than ``min_points`` points, or that fails, is left out).
    size : ShapeSize or None
        Extents, area and volume in the file's units (``core.size``).
    sample : (n, 3) float or None
        ``points`` as loaded: in the file's units and coordinates, before centring and
        scaling (what ``core.compare`` aligns and measures).
    """

    points: np.ndarray
    format: str
    cutoff: CutoffResult
    eigenvalues: np.ndarray
    signature: np.ndarray
    areas: np.ndarray
    descriptor: np.ndarray
    descriptor_version: str
    timings: dict[str, float] = field(default_factory=dict)
    features: np.ndarray = field(default_factory=lambda: np.empty(0))
    scan_descriptor: np.ndarray | None = None
    views: np.ndarray = field(default_factory=lambda: np.empty((0, 0), dtype=np.float32))
    size: ShapeSize | None = None
    sample: np.ndarray | None = None

    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])


@contextmanager
def _timed(timings: dict[str, float], stage: str) -> Iterator[None]:
    start = time.perf_counter()
    yield
    timings[stage] = round(time.perf_counter() - start, 6)


def describe(
    source: str | os.PathLike[str] | bytes,
    settings: EngineSettings | None = None,
    *,
    filename: str | None = None,
    predictor: CutoffPredictor | None = None,
    scan: bool = False,
    views: int = 0,
) -> Description:
    """Describe one shape file.

    Parameters
    ----------
    source : path or bytes
        The file, or its content (then ``filename`` tells the format by its extension).
    settings : EngineSettings, optional
        Defaults to ``EngineSettings()``.
    filename : str, optional
        Original file name, used to detect the format of ``bytes``.
    predictor : CutoffPredictor, optional
        Fitted on models of the same descriptor version: the adaptive cutoff then solves
        straight to the predicted n (same n, usually fewer solver calls).
    scan : bool
        Also give ``scan_descriptor`` (the shape described as a partial scan).
    views : int
        Also describe this many virtual views (``Description.views``); implies ``scan``.

    Raises
    ------
    core.errors.InvalidShapeError
        The file or its geometry cannot be described; the message says why.
    core.errors.SolverError
        A numerical step failed.
    """
    settings = settings or EngineSettings()
    settings.validate()
    timings: dict[str, float] = {}
    start = time.perf_counter()
    with _timed(timings, "load"):
        shape = load_points(
            source,
            filename=filename,
            max_points=settings.max_points,
            min_points=settings.min_points,
            seed=settings.sample_seed,
            remove_outliers=settings.outlier_filter,
            outlier_ratio=settings.outlier_ratio,
        )
    description = _describe_loaded(shape, settings, timings, predictor, scan or views > 0)
    if views > 0:
        _describe_views(description, settings, views)
    timings["total"] = round(time.perf_counter() - start, 6)
    return description


def describe_points(
    points: np.ndarray,
    settings: EngineSettings | None = None,
    *,
    predictor: CutoffPredictor | None = None,
    scan: bool = False,
    views: int = 0,
) -> Description:
    """Describe an in-memory point cloud, ``points : (n, 3) float`` (see ``describe``)."""
    from core.io import validate_points

    settings = settings or EngineSettings()
    settings.validate()
    timings: dict[str, float] = {}
    start = time.perf_counter()
    with _timed(timings, "load"):
        checked = validate_points(
            np.asarray(points, dtype=np.float64),
            max_points=settings.max_points,
            min_points=settings.min_points,
            seed=settings.sample_seed,
            remove_outliers=settings.outlier_filter,
            outlier_ratio=settings.outlier_ratio,
        )
    shape = LoadedShape(points=checked, format="array", kind="points", n_input=len(points))
    description = _describe_loaded(shape, settings, timings, predictor, scan or views > 0)
    if views > 0:
        _describe_views(description, settings, views)
    timings["total"] = round(time.perf_counter() - start, 6)
    return description


def normalised_operators(
    points: np.ndarray, settings: EngineSettings
) -> tuple[np.ndarray, sp.csr_matrix, sp.csr_matrix]:
    """Centre and scale ``points : (n, 3) float`` and build the Laplacian ``(L, M)``.

    Returns the normalised points, the stiffness ``L`` and the mass ``M`` (trace 1 under
    unit-area normalisation).
    """
    points = centre(points)
    if settings.normalisation == "bbox":
        points = points * unit_bbox_scale(points)
    with pin_blas_threads():
        stiffness, mass = build_laplacian(points, method=settings.laplacian)
    if settings.normalisation == "area":
        points, mass = unit_area_mass(points, mass)
    return points, stiffness, sp.csr_matrix(mass)


def descriptor_from_eigenpairs(
    eigenvalues: np.ndarray,
    eigenvectors: np.ndarray,
    areas: np.ndarray,
    points: np.ndarray | None,
    settings: EngineSettings,
    timings: dict[str, float] | None = None,
) -> tuple[np.ndarray, np.ndarray, str]:
    """Signature and descriptor from eigenpairs already computed.

    Parameters
    ----------
    eigenvalues : (k,) float
    eigenvectors : (n, k) float
    areas : (n,) float
        Diagonal of the mass matrix.
    points : (n, 3) float or None
        The points the operators were built on, for the extrinsic blocks (which do not
        depend on position or scale, so normalised or not gives the same vector); None
        only for settings without them.

    Returns
    -------
    signature : (n, s) float
    descriptor : (d,) float32
    descriptor_version : str
    """
    timings = {} if timings is None else timings
    spec = DescriptorSpec.from_settings(settings.descriptor)
    with _timed(timings, "signature"):
        signature = spec.signature(eigenvalues, eigenvectors)
    with _timed(timings, "descriptor"):
        descriptor = spec.histogram(signature, areas, eigenvalues, points)
    return signature, descriptor, spec.version(settings)


def scan_weights(points: np.ndarray, settings: EngineSettings) -> np.ndarray:
    """``core.views.boundary_weights`` of ``points : (n, 3) float`` with ``settings.views``'
    parameters: ``(n,)`` in [0, 1], all ones on a closed surface, and everywhere when
    ``settings.views.boundary_weights`` is off."""
    views = settings.views
    if not views.boundary_weights:
        return np.ones(len(points))
    return boundary_weights(
        points,
        neighbours=views.boundary_neighbours,
        threshold=views.boundary_threshold,
        reach=views.boundary_reach,
    )


def _describe_views(description: Description, settings: EngineSettings, count: int) -> None:
    """Fill ``description.views`` with the scan descriptors of ``count`` virtual views of
    its (already loaded, normalised) points."""
    timings = description.timings
    rows = []
    # Views of one shape need about the same n: each solves straight to the n of the one
    # before (the first to the shape's), which changes the solver calls, never n.
    prediction = int(description.cutoff.n)
    with _timed(timings, "views"):
        parts = virtual_views(
            description.points, count, settings.views.distance, settings.views.hpr_exponent
        )
        for part in parts:
            if len(part) < settings.min_points:  # too little seen to describe
                continue
            shape = LoadedShape(points=part, format="array", kind="points", n_input=len(part))
            try:
                view = _describe_loaded(
                    shape, settings, {}, scan=True, prediction=prediction, measure_size=False
                )
            except (InvalidShapeError, SolverError, ValueError, np.linalg.LinAlgError):
                # A degenerate view (a sliver of a face seen edge-on) is an extra entry that
                # cannot be had; the model and its other views remain.
                continue
            assert view.scan_descriptor is not None
            rows.append(view.scan_descriptor)
            prediction = int(view.cutoff.n)
    width = len(description.descriptor)
    description.views = (
        np.stack(rows).astype(np.float32) if rows else np.empty((0, width), dtype=np.float32)
    )


def _describe_loaded(
    shape: LoadedShape,
    settings: EngineSettings,
    timings: dict[str, float],
    predictor: CutoffPredictor | None = None,
    scan: bool = False,
    prediction: int | None = None,
    measure_size: bool = True,
) -> Description:
    with _timed(timings, "laplacian"):
        points, stiffness, mass = normalised_operators(shape.points, settings)
    # A virtual view keeps only its scan descriptor: measuring its size (an oriented box,
    # a fifth of a view's time) would be thrown away.
    size = shape.size or (_cloud_size(shape.points, points, mass) if measure_size else None)
    features = shape_features(points, mass)
    with pin_blas_threads(), _timed(timings, "eigensolve"):
        # One solver per model: the cutoff's rounds continue the spectrum it already has.
        solver = SpectralSolver(stiffness, mass)
        rule = make_cutoff(settings.cutoff)
        if isinstance(rule, AdaptiveCutoff):
            if prediction is None and predictor is not None:
                prediction = predictor.predict(features)
            cutoff = rule.select(solver, prediction=prediction)
        else:
            cutoff = rule.select(solver)
        eigenvalues, eigenvectors = solver.solve(cutoff.n)
    areas = np.asarray(mass.diagonal(), dtype=np.float64)
    signature, descriptor, version = descriptor_from_eigenpairs(
        eigenvalues, eigenvectors, areas, points, settings, timings
    )
    scan_descriptor = None
    if scan:
        with _timed(timings, "boundary"):
            weights = scan_weights(points, settings)
            # A closed surface has no rim: its scan descriptor is its descriptor.
            scan_descriptor = descriptor
            if not np.all(weights == 1.0):
                scan_descriptor = descriptor_from_eigenpairs(
                    eigenvalues, eigenvectors, areas * weights, points, settings
                )[1]
    return Description(
        points=points,
        format=shape.format,
        cutoff=cutoff,
        eigenvalues=eigenvalues,
        signature=signature,
        areas=areas / areas.sum(),
        descriptor=descriptor,
        descriptor_version=version,
        timings=timings,
        features=features,
        scan_descriptor=scan_descriptor,
        size=size,
        sample=shape.points,
    )


def _cloud_size(raw: np.ndarray, normalised: np.ndarray, mass: sp.spmatrix) -> ShapeSize:
    """A point cloud's size in its own units: extents of ``raw : (n, 3)``, and the area of
    the mass matrix built on ``normalised : (n, 3)`` (the same points, centred and scaled),
    scaled back."""
    scale = float(np.linalg.norm(normalised) / np.linalg.norm(raw - raw.mean(axis=0)))
    return ShapeSize.of_points(raw, float(mass.diagonal().sum()) / scale**2)
