"""/v1/jobs: one describe job, and a tenant's jobs newest first."""

from __future__ import annotations

import uuid
from typing import Annotated, Literal

from fastapi import APIRouter, Query
from pydantic import BaseModel, Field
from sqlalchemy import and_, or_, select

from app.api.cursors import KeysetCursor, encode_keyset, keyset_after
from app.api.deps import SessionDep
from app.api.problems import Problem, problem_responses
from app.api.schemas import JobResource, job_resource
from app.auth.dependency import TenantDep
from app.db.models import Job

__all__ = ["JobList", "router"]

router = APIRouter(prefix="/v1", tags=["jobs"])


class JobList(BaseModel):
    items: list[JobResource]
    next_cursor: str | None = Field(description="Pass as `cursor` for the next page; null: last.")


@router.get(
    "/jobs",
    response_model=JobList,
    responses=problem_responses(401, 422),
    summary="List jobs, newest first",
)
def list_jobs(
    tenant: TenantDep,
    session: SessionDep,
    status: Literal["queued", "running", "done", "failed"] | None = None,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
    cursor: KeysetCursor = "",
) -> JobList:
    query = select(Job).where(Job.tenant == tenant)
    if status is not None:
        query = query.where(Job.status == status)
    if (after := keyset_after(cursor)) is not None:
        created_at, job_id = after
        query = query.where(
            or_(Job.created_at < created_at, and_(Job.created_at == created_at, Job.id < job_id))
        )
    rows = session.scalars(
        query.order_by(Job.created_at.desc(), Job.id.desc()).limit(limit + 1)
    ).all()
    page = rows[:limit]
    next_cursor = encode_keyset(page[-1]) if len(rows) > limit else None
    return JobList(items=[job_resource(job) for job in page], next_cursor=next_cursor)


@router.get(
    "/jobs/{job_id}",
    response_model=JobResource,
    responses=problem_responses(401, 404),
    summary="One job",
)
def get_job(
    job_id: str,
    tenant: TenantDep,
    session: SessionDep,
) -> JobResource:
    try:
        parsed = uuid.UUID(job_id)
    except ValueError:
        parsed = None
    job = (
        session.scalar(select(Job).where(Job.id == parsed, Job.tenant == tenant))
        if parsed is not None
        else None
    )
    if job is None:
        raise Problem("job-not-found", f"There is no job {job_id}.")
    return job_resource(job)
