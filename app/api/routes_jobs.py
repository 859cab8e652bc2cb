"""GET /v1/jobs/{id}: the state of a describe job."""

from __future__ import annotations

import uuid

from fastapi import APIRouter
from sqlalchemy import select

from app.api.auth import TenantDep
from app.api.deps import SessionDep
from app.api.problems import Problem, problem_responses
from app.api.schemas import JobResource, job_resource
from app.db.models import Job

__all__ = ["router"]

router = APIRouter(prefix="/v1", tags=["jobs"])


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
        raise Problem(404, f"There is no job {job_id}.", slug="job-not-found")
    return job_resource(job)
