"""GET /v1/models/{id}/compare/{other_id}: why two parts match (``app.search.comparing``)."""

from __future__ import annotations

import math
from typing import Annotated, Any

import numpy as np
from fastapi import APIRouter, Query
from sqlalchemy import Row, select

from app.api.deps import ServicesDep
from app.api.lookups import model_not_found, parse_model_id
from app.api.problems import Problem, problem_responses
from app.api.schemas import (
    AlignmentRecord,
    ComparePoints,
    CompareResponse,
    DeviationFigures,
    Extents,
    ModelSummary,
    PointSet,
    PointsSources,
    size_of,
)
from app.auth.dependency import TenantDep
from app.db.models import Model
from app.search.comparing import (
    BUDGET_SECONDS,
    MAX_RETURNED_POINTS,
    RETRY_AFTER_SECONDS,
    ComparisonBusy,
    cache_key,
    point_rows,
    returned_points,
)
from core.compare import Alignment, Comparison, Direction, diagonal

__all__ = ["alignment_record", "busy_problem", "deviation_figures", "point_sets", "router"]

router = APIRouter(prefix="/v1", tags=["models"])

_COLUMNS = (Model.id, Model.external_id, Model.name, Model.meta, Model.status,
            Model.descriptor_version, Model.updated_at, Model.size_length, Model.size_width,
            Model.size_height, Model.size_area, Model.size_volume, Model.units)


@router.get(
    "/models/{model_id}/compare/{other_id}",
    response_model=CompareResponse,
    responses=problem_responses(401, 404, 409, 422, 503),
    summary="Why two parts match: one placed on the other, and their deviations",
    description="Places `other_id` on `model_id` (a rotation and translation, with "
    "`scale=true` also a uniform scale): principal axes with their ambiguities tried (sign "
    "flips, and turns where two spreads are close), each start refined by ICP, the best "
    "result kept. Then, in the model's units, how far each part's points lie from the "
    "other's surface (as sampled) both ways: RMS, mean, 95th percentile, maximum and the "
    "share within `tolerance` (default 1 % of the larger bounding-box diagonal), and the "
    "other's extents over the model's along the model's principal axes. `points=N` adds N "
    "points of each part, aligned, with their deviations. Both models must be ready (409 "
    "`model-not-ready`). Computed on request on at most 3000 points of each part (a few "
    "tenths of a second) and kept in a small cache; at most a few run at once, each within "
    f"{BUDGET_SECONDS:g} s: beyond, 503 `busy` with Retry-After.",
)
def compare_models(
    model_id: str,
    other_id: str,
    tenant: TenantDep,
    services: ServicesDep,
    scale: Annotated[bool, Query(description="Also find a uniform scale (parts in other "
                                 "units, or a family member at another size).")] = False,
    tolerance: Annotated[float | None, Query(
        gt=0, allow_inf_nan=False,
        description="Distance within which a point counts as matched, in the model's units "
        "(default: 1 % of the larger bounding-box diagonal).")] = None,
    points: Annotated[int, Query(
        ge=0, le=MAX_RETURNED_POINTS,
        description="Return up to this many points of each part (a seeded subset of at "
        "most 3000) with their deviations.")] = 0,
) -> CompareResponse:
    ids = [parse_model_id(model_id), parse_model_id(other_id)]
    with services.sessions() as session:
        rows = {row.id: row for row in session.execute(
            select(*_COLUMNS).where(Model.tenant == tenant,
                                    Model.id.in_([i for i in ids if i is not None]))
        )}
        for text, parsed in zip((model_id, other_id), ids, strict=True):
            row = rows.get(parsed) if parsed is not None else None
            if row is None:
                raise model_not_found(text)
            if row.status != "ready" or row.descriptor_version is None:
                raise Problem(
                    "model-not-ready",
                    f"Model {row.id} is {row.status}; a comparison needs two ready models.",
                    model_status=row.status,
                )
        model, other = rows[ids[0]], rows[ids[1]]
        stored = point_rows(session, tenant, list({model.id, other.id}))
    first, second = stored.get(model.id), stored.get(other.id)
    for row, found in ((model, first), (other, second)):
        if found is None:
            raise Problem(
                "points-not-available",
                f"Model {row.id} was described before its points were stored; re-describe it "
                f"(POST /v1/models/{row.id}/redescribe) to compare it.",
            )
    assert first is not None and second is not None
    key = cache_key(tenant, model, other, scale, tolerance)
    try:
        compared = services.comparer.compare(key, first, second, scale=scale,
                                             tolerance=tolerance)
    except ComparisonBusy as error:
        raise busy_problem(str(error)) from error
    comparison = compared.comparison
    measured = comparison.deviations
    unit = diagonal(comparison.a_points)
    alignment = alignment_record(comparison.alignment)
    if compared.conversion != 1.0:  # other's points were converted to the model's units
        alignment.scale *= compared.conversion
    return CompareResponse(
        model=_summary(model),
        other=_summary(other),
        units=model.units,
        alignment=alignment,
        tolerance=measured.tolerance,
        model_to_other=deviation_figures(measured.a_to_b),
        other_to_model=deviation_figures(measured.b_to_a),
        size_ratios=[float(r) for r in measured.size_ratios],
        extents=Extents(model=_rounded(measured.extents_a, unit),
                        other=_rounded(measured.extents_b, unit)),
        points_source=PointsSources(model=compared.model.source, other=compared.other.source),
        points=point_sets(comparison, points, unit) if points else None,
    )


def busy_problem(reason: str) -> Problem:
    """The 503 of a comparison that could not run now."""
    return Problem(
        "busy", f"The comparison could not be computed now: {reason}; retry in "
        f"{RETRY_AFTER_SECONDS} s.",
        headers={"Retry-After": str(RETRY_AFTER_SECONDS)},
    )


def alignment_record(alignment: Alignment) -> AlignmentRecord:
    """The API's record of a ``core.compare.Alignment``."""
    return AlignmentRecord(
        rotation=[[float(v) for v in row] for row in alignment.rotation],
        translation=[float(v) for v in alignment.translation],
        scale=float(alignment.scale),
        candidates=alignment.candidates,
    )


def deviation_figures(direction: Direction) -> DeviationFigures:
    return DeviationFigures(rms=direction.rms, mean=direction.mean, p95=direction.p95,
                            max=direction.max, within=direction.within)


def point_sets(comparison: Comparison, count: int, unit: float) -> ComparePoints:
    """``count`` points of each part of ``comparison`` with their deviations, rounded to
    about a millionth of ``unit`` (the model's diagonal)."""
    (a, a_dev), (b, b_dev) = returned_points(comparison, count)
    return ComparePoints(
        model=PointSet(positions=_rounded(a, unit), deviations=_rounded(a_dev, unit)),
        other=PointSet(positions=_rounded(b, unit), deviations=_rounded(b_dev, unit)),
    )


def _rounded(values: np.ndarray, unit: float) -> Any:
    """``values`` as nested lists, rounded to about a millionth of ``unit``."""
    decimals = max(0, 6 - math.ceil(math.log10(unit))) if unit > 0 else 6
    rounded: Any = np.round(np.asarray(values, dtype=np.float64), decimals).tolist()
    return rounded


def _summary(row: Row[Any]) -> ModelSummary:
    return ModelSummary(
        id=row.id, external_id=row.external_id, name=row.name, metadata=row.meta or {},
        size=size_of(row.size_length, row.size_width, row.size_height, row.size_area,
                     row.size_volume, row.units),
    )
