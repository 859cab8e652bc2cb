"""Counts over a tenant's models: how far a re-describe has come, and the cutoff plot.

    GET /v1/stats          models per status and per descriptor_version, jobs per status
    GET /v1/stats/cutoff   cutoff n against point count (Figure 7): counted over every ready
                           model, plotted from at most 2,000 of them
"""

from __future__ import annotations

import math
import uuid
from typing import Any

from fastapi import APIRouter
from pydantic import BaseModel, Field
from sqlalchemy import ColumnElement, func, select
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


# The most models ``GET /v1/stats/cutoff`` plots: at 10^5 ready models the whole list took
# 6.6 s and 29.9 MB a request (+357 MB of memory; bench/cutoff_stats.py), and the viewer
# asked every 3 s.
PLOTTED_MAX = 2000


class CutoffStats(BaseModel):
    """The paper's Figure 7 for this database, and the solver-calls histogram."""

    fixed_n: int = Field(description="The fixed cutoff the adaptive one is compared with.")
    ready_models: int = Field(description="Ready models with a cutoff record.")
    mean_n: float | None = Field(
        description="Their mean adaptive cutoff n (null without any)."
    )
    models: list[CutoffPoint] = Field(
        description=f"At most {PLOTTED_MAX} of them in point-count order: all of them, or "
        "every k-th by point count when there are more (a plot of every model of a large "
        "catalogue weighed tens of megabytes)."
    )
    solver_calls: list[SolverCallsBin] = Field(
        description="Ready models per solver-call count (every one of them)."
    )


@router.get(
    "/stats/cutoff",
    tags=["viewer"],
    response_model=CutoffStats,
    responses=problem_responses(401),
    summary="Cutoff n against point count for the ready models (the paper's Figure 7)",
)
def get_cutoff_stats(tenant: TenantDep, session: SessionDep, services: ServicesDep) -> CutoffStats:
    plotted = (
        Model.tenant == tenant,
        Model.status == "ready",
        Model.cutoff.is_not(None),
        Model.n_points.is_not(None),
    )
    calls = _solver_calls(Model.cutoff)
    histogram = session.execute(  # per solver-call count: its models and the sum of their n
        select(calls, func.count(), func.sum(Model.cutoff["n"].as_float()))
        .where(*plotted)
        .group_by(calls)
        .order_by(calls)
    ).all()
    ready = sum(models for _, models, _ in histogram)
    return CutoffStats(
        fixed_n=services.settings.cutoff_n,
        ready_models=ready,
        mean_n=sum(float(n) for _, _, n in histogram) / ready if ready else None,
        models=_plotted(session, plotted, step=max(1, math.ceil(ready / PLOTTED_MAX))),
        solver_calls=[SolverCallsBin(solver_calls=c, models=m) for c, m, _ in histogram],
    )


def _solver_calls(cutoff: Any) -> ColumnElement[int]:
    """The record's solver calls, also where records written before ``CutoffRecord`` had
    its present form kept them under ``params`` (``CutoffRecord.from_json``)."""
    return func.coalesce(
        cutoff["solver_calls"].as_integer(), cutoff[("params", "solver_calls")].as_integer()
    )


def _plotted(
    session: Session, plotted: tuple[ColumnElement[bool], ...], step: int
) -> list[CutoffPoint]:
    """Every ``step``-th ready model by point count, in that order."""
    ranked = (
        select(
            Model.id, Model.external_id, Model.name, Model.n_points, Model.cutoff,
            func.row_number().over(order_by=(Model.n_points, Model.index_id)).label("place"),
        )
        .where(*plotted)
        .subquery()
    )
    rows = session.execute(
        select(ranked).where((ranked.c.place - 1) % step == 0).order_by(ranked.c.place)
    ).all()
    return [
        CutoffPoint(
            id=row.id,
            external_id=row.external_id,
            name=row.name,
            n_points=row.n_points,
            cutoff=CutoffRecord.from_json(row.cutoff),
        )
        for row in rows
    ]
