"""/v1/duplicates: the duplicates report, computed by a job and then paged.

    POST /v1/duplicates   202 + a ``duplicates`` job that computes and stores the report
    GET  /v1/duplicates   a page of the newest stored report with the given parameters

The computation is in ``app.search.duplicates``, the storage in
``app.search.duplicate_reports``. A GET reads no descriptor: it pages stored rows.
"""

from __future__ import annotations

import uuid
from datetime import datetime
from typing import Annotated, Any

from fastapi import APIRouter, Query, Response
from pydantic import BaseModel, ConfigDict, Field
from sqlalchemy import Row
from sqlalchemy.orm import Session

from app.api.assembly_schemas import summary_of
from app.api.cursors import GroupCursor, encode_group, group_after
from app.api.deps import ServicesDep, SessionDep
from app.api.problems import Problem, problem_responses
from app.api.schemas import JobResource, WhereUsedEntry, job_resource
from app.auth.dependency import TenantDep
from app.db.models import DuplicateReport
from app.search.assemblies import where_used_of_groups
from app.search.duplicate_reports import (
    enqueue_report,
    group_page,
    is_stale,
    latest_report,
    member_names,
    report_of,
)
from app.search.duplicates import DEFAULT_MIN_SCORE, DuplicatesQuery

__all__ = ["router"]

router = APIRouter(prefix="/v1", tags=["search"])

_MEANING = (
    "Connected components of the k-nearest-neighbour graph of the tenant's ready "
    "descriptors of one descriptor_version (k = 16), keeping edges with score >= min_score. "
    "The descriptor is intrinsic and scale-normalised: mirror images and uniformly scaled "
    "copies group with their part: without size_tolerance the report answers 'which parts "
    "are alike at any size' (families); with it (e.g. 0.02: every extent within 2%, in "
    "millimetres where units are known) 'do we already have this part' (true duplicates)."
)
MinScore = Annotated[float, Field(ge=0.5, le=1)]
SizeTolerance = Annotated[
    float | None,
    Field(ge=0, le=10, description="Same size too: every extent within this relative "
          "tolerance (models without a size then group with none); null: any size."),
]


class DuplicatesRequest(BaseModel):
    # Strict: `false` is not a tolerance of 0 (the schema says number).
    model_config = ConfigDict(strict=True, extra="forbid")

    min_score: MinScore = DEFAULT_MIN_SCORE
    size_tolerance: SizeTolerance = None
    descriptor_version: str | None = Field(
        default=None, max_length=255, description="Default: the service's current one."
    )


class DuplicateMember(BaseModel):
    id: uuid.UUID
    external_id: str | None = Field(description="As the model is now; null also for a "
                                    "model deleted since the report (which is then stale).")
    name: str | None


class DuplicatePair(BaseModel):
    a: uuid.UUID
    b: uuid.UUID
    score: float


class DuplicateGroupResource(BaseModel):
    number: int = Field(description="The group's place in the report, 1 = largest.")
    size: int
    members: list[DuplicateMember] = Field(description="Oldest model first.")
    pairs: list[DuplicatePair] = Field(
        description="The edges that joined the group, best first: pairs at least min_score "
        "alike of which one is among the other's 16 most alike parts (at least size - 1 "
        "of them; in a small group, usually every pair)."
    )
    # Only when asked with where_used=true (absent otherwise, not null).
    where_used: list[WhereUsedEntry] | None = Field(
        default=None,
        exclude_if=lambda value: value is None,
        description="With `where_used=true` only: the assemblies that place any member of "
        "the group, oldest first, with the members' placements counted and the members "
        "placed (`parts`). Two or more: the same part used across assemblies.",
    )


class DuplicateReportResource(BaseModel):
    id: uuid.UUID
    job_id: uuid.UUID | None = Field(description="The job that computed it; null when "
                                     "`shapesearch duplicates` did.")
    descriptor_version: str
    min_score: float
    size_tolerance: float | None = Field(description="As asked: null groups parts of any "
                                         "size (families), a number parts of the same size.")
    computed_at: datetime
    models: int = Field(description="Ready models compared.")
    group_count: int = Field(description="Groups in the whole report.")
    exact: bool = Field(
        description="true: every pair of models was compared (up to "
        "SHAPESEARCH_INDEX_EXACT_MAX models); false: each model with those of the index's "
        "SHAPESEARCH_INDEX_NPROBE inverted lists nearest its own (scores stay exact)."
    )
    stale: bool = Field(
        description="Models of the tenant became ready, were re-described or were deleted "
        "since computed_at: POST again for a report of the current models."
    )
    groups: list[DuplicateGroupResource] = Field(description="Largest groups first.")
    next_cursor: str | None = Field(description="Pass as `cursor` for the next page of this "
                                    "report; null: last.")


@router.post(
    "/duplicates",
    status_code=202,
    response_model=JobResource,
    responses=problem_responses(401, 422),
    summary="Compute the duplicates report (a job)",
    description=f"{_MEANING} A worker computes the report and stores it; poll the job "
    "(Location), then page it with GET /v1/duplicates and the same parameters. While a job "
    "with the same parameters is queued or running, that job is answered.",
)
def compute_duplicates(
    response: Response,
    tenant: TenantDep,
    services: ServicesDep,
    body: DuplicatesRequest | None = None,
) -> JobResource:
    asked = body or DuplicatesRequest()
    query = DuplicatesQuery(
        descriptor_version=asked.descriptor_version or services.descriptor_version,
        min_score=asked.min_score,
        size_tolerance=asked.size_tolerance,
    )
    with services.sessions.begin() as session:
        resource = job_resource(enqueue_report(session, tenant, query))
    response.headers["Location"] = f"/v1/jobs/{resource.id}"
    return resource


@router.get(
    "/duplicates",
    response_model=DuplicateReportResource,
    responses=problem_responses(401, 404, 422),
    summary="A page of the stored duplicates report",
    description=f"{_MEANING} The newest report computed (POST /v1/duplicates) with exactly "
    "these parameters; 404 `duplicates-report-not-found` when there is none. With a "
    "cursor, the next page of the report the cursor came from (the parameters are then "
    "ignored): pages never shift, whatever models are added meanwhile; `stale` says "
    "whether they were.",
)
def get_duplicates(
    tenant: TenantDep,
    services: ServicesDep,
    session: SessionDep,
    min_score: Annotated[float, Query(ge=0.5, le=1)] = DEFAULT_MIN_SCORE,
    size_tolerance: Annotated[
        float | None,
        Query(ge=0, le=10, description="As the report was asked with; absent: the report "
              "without one (families)."),
    ] = None,
    descriptor_version: Annotated[
        str | None, Query(max_length=255, description="Default: the service's current one.")
    ] = None,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
    cursor: GroupCursor = "",
    where_used: Annotated[bool, Query(
        description="true: each group also lists `where_used`, the assemblies that place "
        "its members (the same part used across assemblies).")] = False,
) -> DuplicateReportResource:
    position = group_after(cursor)
    if position is not None:
        report, after = _cursor_report(session, tenant, *position)
    else:
        query = DuplicatesQuery(
            descriptor_version=descriptor_version or services.descriptor_version,
            min_score=min_score,
            size_tolerance=size_tolerance,
        )
        report, after = _newest_report(session, tenant, query), 0
    page = _report_page(session, report, group_page(session, report.id, after, limit))
    if where_used:  # issue 76
        uses = where_used_of_groups(session.connection(), tenant,
                                    [[m.id for m in group.members] for group in page.groups])
        for group, used in zip(page.groups, uses, strict=True):
            group.where_used = [
                WhereUsedEntry(assembly=summary_of(entry.assembly), count=entry.count,
                               parts=entry.parts) for entry in used]
    return page


def _cursor_report(
    session: Session, tenant: str, report_id: uuid.UUID, after: int
) -> tuple[DuplicateReport, int]:
    """The report a cursor pages and the group number it continues after."""
    report = report_of(session, tenant, report_id)
    if report is None:
        raise Problem(
            "duplicates-report-not-found",
            "The report this cursor pages was replaced by newer ones; GET without a cursor "
            "for the newest.",
        )
    return report, after


def _newest_report(session: Session, tenant: str, query: DuplicatesQuery) -> DuplicateReport:
    report = latest_report(session, tenant, query)
    if report is None:
        raise Problem(
            "duplicates-report-not-found",
            f"There is no duplicates report with min_score={query.min_score}, "
            f"size_tolerance={_shown(query.size_tolerance)} and descriptor_version="
            f"{query.descriptor_version} yet: POST /v1/duplicates with these parameters, "
            "then GET again once its job is done.",
        )
    return report


def _report_page(
    session: Session, report: DuplicateReport, page: list[Row[Any]]
) -> DuplicateReportResource:
    names = member_names(session, report.tenant, (m for group in page for m in group.members))
    last = page[-1].number if page else report.group_count
    return DuplicateReportResource(
        id=report.id,
        job_id=report.job_id,
        descriptor_version=report.descriptor_version,
        min_score=report.min_score,
        size_tolerance=report.size_tolerance,
        computed_at=report.computed_at,
        models=report.models,
        group_count=report.group_count,
        exact=report.exact,
        stale=is_stale(session, report),
        groups=[_group(group, names) for group in page],
        next_cursor=encode_group(report.id, last) if last < report.group_count else None,
    )


def _group(
    group: Row[Any], names: dict[str, tuple[str | None, str | None]]
) -> DuplicateGroupResource:
    """One stored group (``number``, ``members``, ``pairs``) as the API shows it."""
    # Ids stay the stored strings: pydantic checks them as UUIDs (faster than uuid.UUID).
    members = group.members
    unknown = (None, None)
    return DuplicateGroupResource.model_validate({
        "number": group.number,
        "size": len(members),
        "members": [
            {"id": m, "external_id": names.get(m, unknown)[0], "name": names.get(m, unknown)[1]}
            for m in members
        ],
        "pairs": [
            {"a": members[int(i)], "b": members[int(j)], "score": score}
            for i, j, score in group.pairs
        ],
    })


def _shown(value: float | None) -> str:
    return "null" if value is None else str(value)
