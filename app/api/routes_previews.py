"""What the viewer draws: ``GET /v1/models/{id}/preview`` and ``GET /v1/stats/cutoff``.

The preview is the binary blob of ``app.previews`` (points, HKS per time, eigenvalues),
served with an ETag so a browser fetches it once per description. The cutoff statistics are
the paper's Figure 7 for this database: the cutoff n against the point count of every ready
model, next to the fixed cutoff, and how many solver calls the cutoff needed.
"""

from __future__ import annotations

import hashlib
import uuid
from collections import Counter

from fastapi import APIRouter, Header, Response
from pydantic import BaseModel, Field
from sqlalchemy import select

from app.api.auth import TenantDep
from app.api.deps import ServicesDep, SessionDep
from app.api.problems import Problem, problem_responses
from app.api.routes_models import load_model
from app.db.models import Model
from app.previews import PREVIEW_POINTS

__all__ = ["CutoffPoint", "CutoffStats", "SolverCallsBin", "router"]

router = APIRouter(prefix="/v1", tags=["viewer"])

PREVIEW_MEDIA_TYPE = "application/vnd.shapesearch.preview"


@router.get(
    "/models/{model_id}/preview",
    response_class=Response,
    responses={
        200: {
            "description": f"Up to {PREVIEW_POINTS} points of the model with their log scaled "
            "heat kernel signature at every time of the descriptor's grid, and the "
            "eigenvalues; binary layout in app/previews.py (little-endian: b'SSP1', uint32 "
            "n, s, k; float32 times[s], eigenvalues[k]; float16 points[n,3], log_hks[n,s]).",
            "content": {PREVIEW_MEDIA_TYPE: {"schema": {"type": "string", "format": "binary"}}},
        },
        304: {"description": "Not modified (If-None-Match matched the ETag)."},
        **problem_responses(401, 404, 409),
    },
    summary="A small point/HKS preview of a ready model, for drawing it",
)
def model_preview(
    model_id: str,
    tenant: TenantDep,
    session: SessionDep,
    if_none_match: str | None = Header(default=None),
) -> Response:
    model = load_model(session, tenant, model_id)
    if model.status != "ready":
        raise Problem(
            409,
            f"Model {model.id} is {model.status}; a preview needs a ready model.",
            slug="model-not-ready",
            model_status=model.status,
        )
    blob = model.preview
    if blob is None:
        raise Problem(
            404,
            f"Model {model.id} was described before previews were stored; upload it again "
            "to get one.",
            slug="preview-not-available",
        )
    # The preview changes only when the model is described again (new version, new bytes).
    digest = hashlib.sha256(f"{model.descriptor_version}\0".encode() + blob).hexdigest()[:32]
    etag = f'"{digest}"'
    headers = {"ETag": etag, "Cache-Control": "private, no-cache"}
    if if_none_match is not None and etag in [tag.strip() for tag in if_none_match.split(",")]:
        return Response(status_code=304, headers=headers)
    return Response(content=blob, media_type=PREVIEW_MEDIA_TYPE, headers=headers)


class CutoffPoint(BaseModel):
    """One ready model on the plot."""

    id: uuid.UUID
    external_id: str | None
    name: str | None
    n_points: int = Field(description="Points the description used.")
    n: int = Field(description="Eigenpairs the cutoff chose.")
    solver_calls: int
    mode: str = Field(description="adaptive or fixed")


class SolverCallsBin(BaseModel):
    solver_calls: int
    models: int


class CutoffStats(BaseModel):
    """The paper's Figure 7 for this database, and the solver-calls histogram."""

    fixed_n: int = Field(description="The fixed cutoff the adaptive one is compared with.")
    models: list[CutoffPoint]
    solver_calls: list[SolverCallsBin] = Field(description="Ready models per solver-call count.")


@router.get(
    "/stats/cutoff",
    response_model=CutoffStats,
    responses=problem_responses(401),
    summary="Cutoff n against point count for every ready model (the paper's Figure 7)",
)
def cutoff_stats(tenant: TenantDep, session: SessionDep, services: ServicesDep) -> CutoffStats:
    rows = session.execute(
        select(Model.id, Model.external_id, Model.name, Model.n_points, Model.cutoff)
        .where(Model.tenant == tenant, Model.status == "ready")
        .order_by(Model.n_points)
    ).all()
    points = [
        CutoffPoint(
            id=row.id,
            external_id=row.external_id,
            name=row.name,
            n_points=row.n_points,
            n=row.cutoff["n"],
            solver_calls=row.cutoff["solver_calls"],
            mode=row.cutoff["mode"],
        )
        for row in rows
        if row.cutoff is not None and row.n_points is not None
    ]
    calls = Counter(point.solver_calls for point in points)
    return CutoffStats(
        fixed_n=services.settings.cutoff_n,
        models=points,
        solver_calls=[SolverCallsBin(solver_calls=c, models=calls[c]) for c in sorted(calls)],
    )
