"""Why two parts match, for the service: the stored points of ready models loaded and handed
to ``core.compare``, bounded and cached.

* ``GET /v1/models/{id}/compare/{other_id}`` places ``other`` on ``id`` (``Comparer.compare``);
* ``POST /v1/search?explain=true`` places the scan on each of its first answers
  (``Comparer.explain``).

A model's points are its ``sample`` (migration 0017: the description's points as loaded, in
the file's units and coordinates); a model described before the sample was kept falls back
to its preview's 2000 points (unit surface area, centred, float16), scaled back by the square
root of ``size_area`` (``PartPoints.source`` says which). Two parts that both declare their
units are compared in the first one's (the other's points converted); otherwise as given,
as sizes are.

A comparison costs a few tenths of a second of CPU (``bench/compare.py``), so, as a search's
describe is, it is bounded: at most ``MAX_CONCURRENT`` run at once in a process (one more is
refused at once: ``ComparisonBusy``), each within ``BUDGET_SECONDS`` (past it:
``ComparisonBusy`` too), on at most ``core.compare.MAX_POINTS`` points of each part. Answers
are kept in a small LRU (``CACHE_SIZE`` entries) keyed by the tenant, both ids, the options,
both descriptor versions and both models' ``updated_at`` (a new revision or a re-describe
changes it).
"""

from __future__ import annotations

import threading
import time
import uuid
from collections import OrderedDict
from collections.abc import Hashable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime
from typing import Any, Literal

import numpy as np
from sqlalchemy import Row, select
from sqlalchemy.orm import Session

from app.db.models import Model
from app.ingest.describing import decode_sample
from app.ingest.previews import decode_preview
from app.search.sizing import millimetres
from core.compare import AlignmentBudgetExceeded, Comparison, compare

__all__ = [
    "BUDGET_SECONDS",
    "CACHE_SIZE",
    "EXPLAINED_RESULTS",
    "MAX_CONCURRENT",
    "MAX_RETURNED_POINTS",
    "RETRY_AFTER_SECONDS",
    "Compared",
    "Comparer",
    "ComparisonBusy",
    "PartPoints",
    "PointsSource",
    "cache_key",
    "part_points",
    "point_rows",
    "returned_points",
]

#: Comparisons computed at once per process; one more is refused (503 ``busy``).
MAX_CONCURRENT = 2
#: Seconds a comparison may take before it is given up (503 ``busy``): about 20x its time
#: on an idle machine.
BUDGET_SECONDS = 5.0
#: Comparisons kept (each holds its per-point figures: about 100 KB).
CACHE_SIZE = 32
#: Seconds a refused comparison is asked to wait.
RETRY_AFTER_SECONDS = 1
#: A search's answers that ``explain=true`` places the scan on, first answers first.
EXPLAINED_RESULTS = 5
#: ``points=N`` is at most this.
MAX_RETURNED_POINTS = 4000

PointsSource = Literal["sample", "preview"]


class ComparisonBusy(RuntimeError):
    """No comparison slot is free, or the comparison took longer than its budget."""


@dataclass(frozen=True)
class PartPoints:
    """A ready model's points for a comparison.

    Attributes
    ----------
    points : (n, 3) float
        In the model's units (``units``).
    source : {"sample", "preview"}
        The stored sample, or the preview scaled back by ``sqrt(size_area)`` (centred:
        a translation is then relative to the preview's centre, not the file's origin).
    units : str or None
    """

    points: np.ndarray
    source: PointsSource
    units: str | None


def part_points(
    sample: bytes | None, preview: bytes | None, size_area: float | None, units: str | None
) -> PartPoints | None:
    """The points of a model's stored ``sample``, else of its ``preview`` (scaled back
    by ``sqrt(size_area)``, or left at unit area without a size); None without either."""
    if sample:
        return PartPoints(decode_sample(sample), "sample", units)
    if preview:
        points = decode_preview(preview).points.astype(np.float64)
        factor = float(np.sqrt(size_area)) if size_area and size_area > 0 else 1.0
        return PartPoints(points * factor, "preview", units)
    return None


def point_rows(
    session: Session, tenant: str, ids: list[uuid.UUID]
) -> dict[uuid.UUID, PartPoints | None]:
    """The ``part_points`` of the tenant's models ``ids`` (read in one query; the preview
    only of models without a sample)."""
    if not ids:
        return {}
    rows = session.execute(
        select(Model.id, Model.sample, Model.size_area, Model.units)
        .where(Model.tenant == tenant, Model.id.in_(ids))
    ).all()
    found: dict[uuid.UUID, PartPoints | None] = {
        row.id: part_points(row.sample, None, row.size_area, row.units) for row in rows
    }
    missing = [model_id for model_id, points in found.items() if points is None]
    if missing:
        for row in session.execute(
            select(Model.id, Model.preview, Model.size_area, Model.units)
            .where(Model.id.in_(missing))
        ):
            found[row.id] = part_points(None, row.preview, row.size_area, row.units)
    return found


def returned_points(
    comparison: Comparison, count: int, seed: int = 0
) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """At most ``count`` points of each part of ``comparison`` (a seeded subset), in the
    first part's frame, each with its deviation: ``((a_positions (n, 3), a_deviations
    (n,)), (b_positions (m, 3), b_deviations (m,)))``."""

    def pick(points: np.ndarray, distances: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if len(points) <= count:
            return points, distances
        rng = np.random.default_rng(seed)
        keep = np.sort(rng.choice(len(points), count, replace=False))
        return points[keep], distances[keep]

    deviations = comparison.deviations
    return (pick(comparison.a_points, deviations.a_to_b.distances),
            pick(comparison.b_points, deviations.b_to_a.distances))


@dataclass(frozen=True)
class Compared:
    """A cached comparison: ``other`` placed on ``model``, with its points' sources."""

    comparison: Comparison
    model: PartPoints
    other: PartPoints
    conversion: float  # other's points were multiplied by this (units), before aligning


class Comparer:
    """Per app: the comparison slots and the cache of recent comparisons."""

    def __init__(
        self,
        *,
        max_concurrent: int = MAX_CONCURRENT,
        budget_seconds: float = BUDGET_SECONDS,
        cache_size: int = CACHE_SIZE,
    ) -> None:
        self.budget_seconds = budget_seconds
        self.cache_size = cache_size
        self.max_concurrent = max_concurrent
        self._slots = threading.BoundedSemaphore(max_concurrent)
        self._cache: OrderedDict[Hashable, Compared] = OrderedDict()
        self._lock = threading.Lock()

    def compare(
        self,
        key: Hashable,
        model: PartPoints,
        other: PartPoints,
        *,
        scale: bool,
        tolerance: float | None,
    ) -> Compared:
        """``other`` placed on ``model`` (``core.compare.compare``), from the cache when
        ``key`` was computed before; ``ComparisonBusy`` when no slot is free or past
        the budget; ``ValueError`` for points that cannot be compared."""
        cached = self._cached(key)
        if cached is not None:
            return cached
        conversion = 1.0
        if model.units is not None and other.units is not None:
            conversion = millimetres(other.units) / millimetres(model.units)
        with self._slot():
            comparison = self._run(
                model.points, other.points * conversion, scale=scale, tolerance=tolerance,
                partial=False,
            )
        compared = Compared(comparison, model, other, conversion)
        self._remember(key, compared)
        return compared

    def explain(self, part: PartPoints, scan: np.ndarray) -> Comparison:
        """The scan ``scan : (m, 3)`` (any units) placed on ``part`` at the part's scale
        (``partial``, ``scale``); ``ComparisonBusy`` past the budget. Not bounded by the
        slots: a search holds one of its own (``SearchDescriber``)."""
        return self._run(part.points, scan, scale=True, tolerance=None, partial=True)

    def _run(
        self, a: np.ndarray, b: np.ndarray, *, scale: bool, tolerance: float | None,
        partial: bool,
    ) -> Comparison:
        deadline = time.monotonic() + self.budget_seconds
        try:
            return compare(a, b, scale=scale, tolerance=tolerance, partial=partial,
                           deadline=deadline)
        except AlignmentBudgetExceeded as error:
            raise ComparisonBusy(
                f"the comparison took longer than its budget of {self.budget_seconds:g} s "
                "(the service is busy)"
            ) from error

    @contextmanager
    def _slot(self) -> Iterator[None]:
        if not self._slots.acquire(blocking=False):
            raise ComparisonBusy(
                f"{self.max_concurrent} comparisons are being computed already"
            )
        try:
            yield
        finally:
            self._slots.release()

    def _cached(self, key: Hashable) -> Compared | None:
        with self._lock:
            found = self._cache.get(key)
            if found is not None:
                self._cache.move_to_end(key)
            return found

    def _remember(self, key: Hashable, compared: Compared) -> None:
        if self.cache_size <= 0:
            return
        with self._lock:
            self._cache[key] = compared
            self._cache.move_to_end(key)
            while len(self._cache) > self.cache_size:
                self._cache.popitem(last=False)


def cache_key(
    tenant: str, model: Row[Any], other: Row[Any], scale: bool, tolerance: float | None
) -> tuple[Hashable, ...]:
    """The cache key of a comparison of two model rows (``id``, ``descriptor_version``,
    ``updated_at``) with its options."""

    def stamp(value: datetime | None) -> str | None:
        return None if value is None else value.isoformat()

    return (tenant, model.id, other.id, bool(scale), tolerance,
            model.descriptor_version, other.descriptor_version,
            stamp(model.updated_at), stamp(other.updated_at))
