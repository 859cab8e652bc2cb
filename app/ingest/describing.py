"""Running the engine for the service: ``core.pipeline.describe`` with BLAS pinned, and the
translation of its ``Description`` into stored columns and API fields."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from sqlalchemy import select
from threadpoolctl import threadpool_limits

from app.db.models import Model
from app.ingest.previews import encode_preview
from core.cutoff import CutoffRecord
from core.cutoff_predictor import CutoffPredictor
from core.descriptor import DescriptorSpec
from core.io import load_points
from core.pipeline import Description, describe
from core.settings import EngineSettings
from core.size import SIZE_FIELDS, ShapeSize

__all__ = [
    "CutoffPredictorCache",
    "describe_upload",
    "decode_sample",
    "described_columns",
    "descriptor_version",
    "encode_sample",
    "ingest_columns",
    "model_columns",
    "pin_blas_threads",
    "SIZE_COLUMNS",
    "quick_check",
    "size_columns",
]

log = logging.getLogger("shapesearch.describing")


def pin_blas_threads() -> None:
    """Give BLAS/OpenMP one thread for the rest of this process.

    Workers and synchronous searches run side by side, one describe per thread; letting each
    also fan out over every core would oversubscribe the machine and slow all of them down.
    Done once per process because the limits are process-wide, not per thread.
    """
    import faiss

    threadpool_limits(limits=1)
    faiss.omp_set_num_threads(1)


def describe_upload(
    content: bytes,
    filename: str,
    settings: EngineSettings,
    predictor: CutoffPredictor | None = None,
    scan: bool = False,
    views: int = 0,
) -> Description:
    """Describe an uploaded file (call ``pin_blas_threads`` once in the process first);
    ``scan`` and ``views`` as in ``core.pipeline.describe``."""
    return describe(
        content, settings, filename=filename, predictor=predictor, scan=scan, views=views
    )


def descriptor_version(settings: EngineSettings) -> str:
    """The ``descriptor_version`` that ``settings`` give every model (no describe needed)."""
    return DescriptorSpec.from_settings(settings.descriptor).version(settings)


def described_columns(
    content: bytes,
    filename: str,
    settings: EngineSettings,
    predictor: CutoffPredictor | None = None,
    scan: bool = False,
    views: int = 0,
) -> dict[str, Any]:
    """``model_columns`` of the file's description: small and picklable, for a sandbox.

    A catalogue part is described with ``scan=True, views=settings.views.count`` (scan mode's
    entries, ``ingest_columns``); a search query with ``scan`` in scan mode only.
    """
    description = describe_upload(content, filename, settings, predictor, scan, views)
    return model_columns(description, settings.descriptor.hks_times)


def ingest_columns(
    content: bytes,
    filename: str,
    settings: EngineSettings,
    predictor: CutoffPredictor | None = None,
) -> dict[str, Any]:
    """``described_columns`` of a catalogue part: with its scan descriptor and the
    ``settings.views.count`` virtual views that scan mode searches (none when 0)."""
    return described_columns(
        content, filename, settings, predictor, True, settings.views.count
    )


def quick_check(content: bytes, name: str, points: int, min_points: int, seed: int) -> None:
    """Parse the file and sample ``points`` points; raises ``InvalidShapeError``. The
    size is left to the describe (a size is never a reason to refuse a file)."""
    load_points(
        content, filename=name, max_points=points, min_points=min_points, seed=seed,
        measure_size=False,
    )


def model_columns(description: Description, hks_times: Sequence[float]) -> dict[str, Any]:
    """The Model columns a finished description fills in; ``hks_times`` is the descriptor's
    time grid, the first columns of ``description.signature`` (its log scaled HKS).
    ``view_descriptors`` is None without views, ``scan_descriptor`` None unless asked for."""
    descriptor = np.ascontiguousarray(description.descriptor, dtype=np.float32)
    scan = description.scan_descriptor
    views = np.ascontiguousarray(description.views, dtype=np.float32)
    return {
        "n_points": description.n_points,
        "cutoff": description.cutoff.record(description.features).to_json(),
        "eigenvalues": [float(v) for v in np.asarray(description.eigenvalues).ravel()],
        "descriptor": descriptor.tobytes(),
        "descriptor_version": description.descriptor_version,
        # Always written, so that a re-describe with fewer (or no) views leaves none stale.
        "view_descriptors": views.tobytes() if len(views) else None,
        "scan_descriptor": None if scan is None else np.asarray(scan, np.float32).tobytes(),
        "timings": {stage: float(seconds) for stage, seconds in description.timings.items()},
        **size_columns(description.size),
        "preview": encode_preview(
            description.points,
            description.signature[:, : len(hks_times)],
            np.asarray(hks_times),
            description.eigenvalues,
        ),
        "sample": encode_sample(description.sample),
    }


def encode_sample(points: np.ndarray | None) -> bytes | None:
    """``Model.sample``: ``points : (n, 3)`` as float32 little-endian bytes (None: none)."""
    if points is None:
        return None
    return np.ascontiguousarray(points, dtype="<f4").tobytes()


def decode_sample(blob: bytes) -> np.ndarray:
    """The ``(n, 3) float64`` points of ``encode_sample``'s bytes; ``ValueError`` for
    bytes that are not whole points."""
    if len(blob) % 12:
        raise ValueError(f"a sample holds whole float32 points, not {len(blob)} bytes")
    return np.frombuffer(blob, dtype="<f4").reshape(-1, 3).astype(np.float64)


#: The Model's size columns (migration 0009), in ``core.size.SIZE_FIELDS`` order.
SIZE_COLUMNS = tuple(f"size_{name}" for name in SIZE_FIELDS)


def size_columns(size: ShapeSize | None) -> dict[str, float | None]:
    """The Model's size columns for ``size`` (all None without one)."""
    values = size.to_json() if size is not None else dict.fromkeys(SIZE_FIELDS)
    return dict(zip(SIZE_COLUMNS, (values[name] for name in SIZE_FIELDS), strict=True))


class CutoffPredictorCache:
    """A ``CutoffPredictor`` fitted on the stored ready models of one descriptor version.

    Refitted from the features and n each model's cutoff record holds: on every job while
    fewer than ``eager_below`` models train it (a young catalogue learns at once, and the
    query is small), then every ``refresh_seconds`` (models keep arriving). With no such
    models ``predictor()`` gives None and the cutoff runs its seed round. Safe to share
    between worker threads.

    Parameters
    ----------
    sessions : sessionmaker
        Database sessions.
    descriptor_version : str
        Only models described with this version (same cutoff rule and points) train it.
    refresh_seconds : float
        Age after which the next ``predictor()`` call refits.
    limit : int
        Most recent models used (bounds memory and fit time on a large catalogue).
    eager_below : int
        Below this many training models, refit on every call.
    """

    def __init__(
        self,
        sessions: Any,
        descriptor_version: str,
        *,
        refresh_seconds: float = 300.0,
        limit: int = 5000,
        eager_below: int = 100,
    ) -> None:
        self.sessions = sessions
        self.descriptor_version = descriptor_version
        self.refresh_seconds = refresh_seconds
        self.limit = limit
        self.eager_below = eager_below
        self._lock = threading.Lock()
        self._fitted_at = -float("inf")
        self._predictor: CutoffPredictor | None = None

    def predictor(self) -> CutoffPredictor | None:
        """The current predictor (refitted if stale), or None while there is no data."""
        with self._lock:
            known = 0 if self._predictor is None else self._predictor.n_samples_
            stale = time.monotonic() - self._fitted_at >= self.refresh_seconds
            if stale or known < self.eager_below:
                self._fitted_at = time.monotonic()
                try:
                    self._predictor = self._fit()
                except Exception:  # the database is away: keep the previous predictor
                    log.exception("cutoff predictor refit failed")
            return self._predictor

    def _fit(self) -> CutoffPredictor | None:
        query = (
            select(Model.cutoff)
            .where(Model.status == "ready", Model.descriptor_version == self.descriptor_version)
            .order_by(Model.index_id.desc())
            .limit(self.limit)
        )
        with self.sessions() as session:
            stored = [record for record in session.scalars(query) if record]
        records = [CutoffRecord.from_json(record) for record in stored]
        rows = [
            (record.features, record.n)
            for record in records
            if record.mode == "adaptive" and record.features
        ]
        if not rows:
            return None
        width = len(rows[0][0])
        rows = [(features, n) for features, n in rows if len(features) == width]
        features = np.array([features for features, _ in rows], dtype=np.float64)
        return CutoffPredictor().fit(features, np.array([n for _, n in rows]))

