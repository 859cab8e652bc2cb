"""GET /v1/duplicates: groups of near-identical parts (see app/search/duplicates.py)."""

from __future__ import annotations

import uuid
from typing import Annotated

from fastapi import APIRouter, Query
from pydantic import BaseModel, Field

from app.api.cursors import OffsetCursor, encode_offset, offset_of
from app.api.deps import ServicesDep, SessionDep
from app.api.problems import problem_responses
from app.auth.dependency import TenantDep
from app.search.duplicates import find_groups

__all__ = ["router"]

router = APIRouter(prefix="/v1", tags=["search"])


class DuplicateMember(BaseModel):
    id: uuid.UUID
    external_id: str | None
    name: str | None


class DuplicatePair(BaseModel):
    a: uuid.UUID
    b: uuid.UUID
    score: float


class DuplicateGroupResource(BaseModel):
    size: int
    members: list[DuplicateMember]
    pairs: list[DuplicatePair] = Field(description="Every pair of members, best first.")


class DuplicateReport(BaseModel):
    descriptor_version: str
    min_score: float
    size_tolerance: float | None = Field(description="As asked: null groups parts of any "
                                         "size (families), a number parts of the same size.")
    groups: list[DuplicateGroupResource] = Field(description="Largest groups first.")
    next_cursor: str | None = Field(description="Pass as `cursor` for the next page; null: last.")


@router.get(
    "/duplicates",
    response_model=DuplicateReport,
    responses=problem_responses(401, 422),
    summary="Groups of parts whose descriptors are at least min_score alike",
    description="Connected components of the k-nearest-neighbour graph of the ready "
    "descriptors (one batched search), keeping edges with score >= min_score. The "
    "descriptor is intrinsic and scale-normalised: mirror images and uniformly scaled copies "
    "group with their part: without size_tolerance the report answers 'which parts are "
    "alike at any size' (families); with it (e.g. 0.02: every extent within 2%, in "
    "millimetres where units are known) 'do we already have this part' (true duplicates). "
    "Default descriptor_version: the service's current one.",
)
def get_duplicates(
    tenant: TenantDep,
    services: ServicesDep,
    session: SessionDep,
    min_score: Annotated[float, Query(ge=0.5, le=1)] = 0.98,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
    cursor: OffsetCursor = "",
    descriptor_version: str | None = None,
    size_tolerance: Annotated[
        float | None,
        Query(ge=0, le=10, description="Same size too: every extent within this relative "
              "tolerance (models without a size then group with none)."),
    ] = None,
) -> DuplicateReport:
    offset = offset_of(cursor)
    version = descriptor_version or services.descriptor_version
    groups = find_groups(session, tenant, version, min_score, size_tolerance=size_tolerance)
    page = groups[offset : offset + limit]
    return DuplicateReport(
        descriptor_version=version,
        min_score=min_score,
        size_tolerance=size_tolerance,
        groups=[
            DuplicateGroupResource(
                size=len(group.members),
                members=[DuplicateMember(**vars(m)) for m in group.members],
                pairs=[
                    DuplicatePair(a=group.members[i].id, b=group.members[j].id, score=score)
                    for i, j, score in group.pairs
                ],
            )
            for group in page
        ],
        next_cursor=encode_offset(offset + limit) if offset + limit < len(groups) else None,
    )
