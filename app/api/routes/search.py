"""POST /v1/search: describe an uploaded scan now and return the most similar models."""

from __future__ import annotations

from typing import Annotated

import numpy as np
from fastapi import APIRouter, Depends, File, Query, Request, UploadFile
from sqlalchemy.orm import Session

from app.api.deps import ServicesDep, SessionDep
from app.api.inputs import fields_once
from app.api.problems import problem_responses
from app.api.routes.assemblies import where_used_entries
from app.api.routes.compare import alignment_record, point_sets
from app.api.schemas import (
    Explanation,
    SearchQuery,
    SearchResponse,
    SearchResult,
    cutoff_record,
    similar_results,
    size_of,
)
from app.api.search_params import (
    FILTER_PARAMETERS,
    ORDER_HELP,
    SCAN_MODE_HELP,
    SIZE_HELP,
    AssemblyQuery,
    ModeQuery,
    SizeOptions,
    UnitsField,
    metadata_filters,
    metadata_ranges,
    query_column,
    size_options,
)
from app.api.uploads import UPLOAD_FILE_HELP, invalid_shape_problem
from app.auth.dependency import TenantDep
from app.ingest.describing import decode_sample
from app.ingest.sandbox import SandboxCrash
from app.search.comparing import (
    EXPLAINED_RESULTS,
    MAX_RETURNED_POINTS,
    Comparer,
    ComparisonBusy,
    point_rows,
)
from app.search.similarity import Match, find_similar
from app.search.sizing import extents_mm
from core.compare import diagonal
from core.errors import InvalidShapeError

__all__ = ["router"]

router = APIRouter(prefix="/v1", tags=["search"])


@router.post(
    "/search",
    response_model=SearchResponse,
    responses=problem_responses(401, 413, 415, 422, 503),
    summary="Find the models most similar to an uploaded scan (nothing is stored)",
    dependencies=[Depends(fields_once)],
    openapi_extra=FILTER_PARAMETERS,
    description="The scan is described synchronously, which takes seconds; at most "
    "SHAPESEARCH_SEARCH_MAX_CONCURRENT at a time (beyond: 503 with Retry-After). A file "
    "seen before (same bytes, same mode) is answered without describing it again. Same "
    "filters, score and order as /v1/models/{id}/similar. " + SCAN_MODE_HELP + ORDER_HELP
    + SIZE_HELP
    + " The query's size is the upload's, in its `units`; a partial scan under-measures."
    + f" With `explain=true` the first {EXPLAINED_RESULTS} results (at most; the others get "
    "none, to bound the cost: about a few tenths of a second each) carry an `explanation`: "
    "the scan placed on the part at the part's scale (the scan's units are unknown), the "
    "scan's RMS distance from the part and the share of the part it covers; `points=N` "
    "adds up to N points of both, aligned, with their deviations.",
)
def search_by_upload(
    request: Request,
    file: Annotated[UploadFile, File(description=UPLOAD_FILE_HELP)],
    filters: Annotated[dict[str, str], Depends(metadata_filters)],
    ranges: Annotated[dict[str, tuple[float | None, float | None]], Depends(metadata_ranges)],
    size: Annotated[SizeOptions, Depends(size_options)],
    tenant: TenantDep,
    services: ServicesDep,
    session: SessionDep,
    k: Annotated[int, Query(ge=1, le=100)] = 10,
    min_score: Annotated[float | None, Query(ge=0, le=1)] = None,
    mode: ModeQuery = "shape",
    units: UnitsField = None,
    explain: Annotated[bool, Query(
        description=f"Place the scan on each of the first {EXPLAINED_RESULTS} results "
        "(at most) and say how well it fits (`explanation`).")] = False,
    points: Annotated[int, Query(
        ge=0, le=MAX_RETURNED_POINTS,
        description="With `explain`: up to this many points of the part and of the aligned scan "
        "in each explanation.")] = 0,
    assembly_id: AssemblyQuery = None,
    where_used: Annotated[bool, Query(
        description="true: each result also lists `where_used`, the assemblies that "
        "contain it or a copy of it (as `GET /v1/models/{id}/where-used`).")] = False,
) -> SearchResponse:
    upload = services.uploads.read(file.file, file.filename, parse=False)
    try:
        # A sync route runs in the threadpool, so describing does not block the event loop.
        described = request.app.state.search_describer.describe(
            upload.content, upload.filename, upload.sha256, session, tenant, mode
        )
    except SandboxCrash as error:
        raise invalid_shape_problem(
            InvalidShapeError("unparsable", f"the file could not be described: {error}")
        ) from error
    matches = find_similar(
        services.index,
        session.connection(),
        (tenant, described["descriptor_version"]),
        np.frombuffer(described[query_column(mode)], dtype=np.float32),
        k=k,
        min_score=min_score,
        filters=filters,
        metadata_ranges=ranges,
        pushdown_max=services.settings.filter_pushdown_max,
        mode=mode,
        assembly_id=assembly_id,
        size=size.query(extents_mm(
            described["size_length"], described["size_width"], described["size_height"], units
        )),
    )
    cutoff = cutoff_record(described["cutoff"])
    assert cutoff is not None
    results = _results(services.comparer, session, tenant, matches,
                       described["descriptor_version"],
                       described.get("sample") if explain else None, points)
    if where_used:  # issue 76
        for result in results:
            result.where_used = where_used_entries(services, session.connection(), tenant,
                                                   result.model.id)
    return SearchResponse(
        query=SearchQuery(
            n_points=described["n_points"],
            cutoff=cutoff,
            descriptor_version=described["descriptor_version"],
            format=upload.format,
            size=size_of(described["size_length"], described["size_width"],
                         described["size_height"], described["size_area"],
                         described["size_volume"], units),
        ),
        results=results,
    )


def _results(
    comparer: Comparer,
    session: Session,
    tenant: str,
    matches: list[Match],
    descriptor_version: str,
    sample: bytes | None,
    points: int,
) -> list[SearchResult]:
    """The answer's results, the first ``EXPLAINED_RESULTS`` explained when the scan's
    ``sample`` is given (a stored model answered for the upload may have none)."""
    results = [SearchResult(**result.model_dump())
               for result in similar_results(matches, descriptor_version)]
    if sample is None:
        return results
    scan = decode_sample(sample)
    explained = matches[:EXPLAINED_RESULTS]
    parts = point_rows(session, tenant, [match.model.id for match in explained])
    for result, match in zip(results, explained, strict=False):
        part = parts.get(match.model.id)
        if part is None:
            continue
        try:
            comparison = comparer.explain(part, scan)
        except ComparisonBusy:  # past its budget: the answer stands, without this one
            continue
        measured = comparison.deviations
        result.explanation = Explanation(
            alignment=alignment_record(comparison.alignment),
            rms=measured.b_to_a.rms,
            coverage=measured.a_to_b.within,
            tolerance=measured.tolerance,
            view=match.view,
            points_source=part.source,
            points=point_sets(comparison, points, diagonal(comparison.a_points))
            if points else None,
        )
    return results
