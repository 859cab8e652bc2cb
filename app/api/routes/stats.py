"""Counts over a tenant's models: how far a re-describe has come, and the cutoff plot.

    GET /v1/stats          models per status and per descriptor_version, jobs per status
    GET /v1/stats/cutoff   cutoff n against point count for every ready model (Figure 7)
"""

from __future__ import annotations

import uuid
from collections import Counter

from fastapi import APIRouter
from pydantic import BaseModel, Field
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.api.deps import ServicesDep, SessionDep
from app.api.problems import problem_responses
from app.auth.dependency import TenantDep
from app.db.models import Job, Model
from core.cutoff import CutoffRecord
from core.descriptor import ENGINE_LIBRARIES, engine_library_versions

__all__ = [
    "CutoffPoint",
    "CutoffStats",
    "SolverCallsBin",
    "Stats",
    "router",
]

router = APIRouter(prefix="/v1")


class Stats(BaseModel):
    models: int
    by_status: dict[str, int] = Field(description="Models per status.")
    by_descriptor_version: dict[str, int] = Field(
        description="Ready models per descriptor_version; only current_descriptor_version "
        "is searched with POST /v1/search."
    )
    jobs_by_status: dict[str, int]
    current_descriptor_version: str
    engine_libraries: dict[str, str] = Field(
        description=f"This API process's versions of the libraries that can change a "
        f"descriptor ({', '.join(ENGINE_LIBRARIES)}). They are part of "
        "current_descriptor_version: after an upgrade of one of them every stored model is "
        "from another version until it is re-described (shapesearch redescribe)."
    )
    ready_without_size: int = Field(
        description="Ready models described before sizes were measured: re-describe them "
        "(shapesearch redescribe --all) for size filters and size-aware ranking."
    )


def _counts(session: Session, column: object, *where: object) -> dict[str, int]:
    rows = session.execute(
        select(column, func.count()).where(*where).group_by(column)  # type: ignore[call-overload]
    ).all()
    return {str(key): int(count) for key, count in rows if key is not None}


@router.get(
    "/stats",
    tags=["models"],
    response_model=Stats,
    responses=problem_responses(401),
    summary="Counts of models per status and per descriptor_version, and of jobs",
)
def get_stats(tenant: TenantDep, services: ServicesDep, session: SessionDep) -> Stats:
    by_status = _counts(session, Model.status, Model.tenant == tenant)
    return Stats(
        models=sum(by_status.values()),
        by_status=by_status,
        by_descriptor_version=_counts(
            session, Model.descriptor_version, Model.tenant == tenant, Model.status == "ready"
        ),
        jobs_by_status=_counts(session, Job.status, Job.tenant == tenant),
        current_descriptor_version=services.descriptor_version,
        engine_libraries=dict(engine_library_versions()),
        ready_without_size=int(session.scalar(
            select(func.count()).where(
                Model.tenant == tenant, Model.status == "ready", Model.size_length.is_(None)
            )
        ) or 0),
    )


class CutoffPoint(BaseModel):
    """One ready model on the plot."""

    id: uuid.UUID
    external_id: str | None
    name: str | None
    n_points: int = Field(description="Points the description used.")
    cutoff: CutoffRecord


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
    tags=["viewer"],
    response_model=CutoffStats,
    responses=problem_responses(401),
    summary="Cutoff n against point count for every ready model (the paper's Figure 7)",
)
def get_cutoff_stats(tenant: TenantDep, session: SessionDep, services: ServicesDep) -> CutoffStats:
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
            cutoff=CutoffRecord.from_json(row.cutoff),
        )
        for row in rows
        if row.cutoff is not None and row.n_points is not None
    ]
    calls = Counter(point.cutoff.solver_calls for point in points)
    return CutoffStats(
        fixed_n=services.settings.cutoff_n,
        models=points,
        solver_calls=[SolverCallsBin(solver_calls=c, models=calls[c]) for c in sorted(calls)],
    )
