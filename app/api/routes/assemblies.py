"""/v1/models/{id}/parts (and its labelled points) and /v1/models/{id}/where-used:
assemblies and their parts (issue 76; the split itself happens at upload,
``app.ingest.assemblies``; the answers come from ``app.search.assemblies``)."""

from __future__ import annotations

import uuid
from typing import Annotated, Any, BinaryIO

from fastapi import APIRouter, Query
from sqlalchemy import Connection, select

from app.api.assembly_schemas import (
    PartPointsResponse,
    PartsResponse,
    PartUse,
    WhereUsedEntry,
    WhereUsedResponse,
    summary_of,
)
from app.api.deps import Services, ServicesDep
from app.api.lookups import model_not_found, parse_model_id
from app.api.problems import Problem, problem_responses
from app.api.uploads import CheckedUpload, invalid_shape_problem
from app.auth.dependency import TenantDep
from app.db.models import Model
from app.ingest.assemblies import PartFile, is_assembly, split_upload, splits_by_default
from app.ingest.sandbox import SandboxCrash
from app.search.assemblies import assembly_parts, labelled_points, where_used
from app.settings import Settings
from core.errors import InvalidShapeError
from core.io import check_gltf_graph

__all__ = [
    "parts_of", "refuse_bomb", "router", "wants_split", "where_used_entries", "with_where_used",
]

router = APIRouter(prefix="/v1", tags=["assemblies"])

#: Most points ``/parts/points`` answers (a describe's sample holds up to 3000 by default).
MAX_LABELLED_POINTS = 10_000


def refuse_bomb(settings: Settings, stream: BinaryIO, assembly: str | None) -> None:
    """Refuse a GLB that is to be split (``assembly``, or the default) whose node graph is a
    bomb (422 ``assembly-too-large``), from its JSON chunk alone, before the upload's own
    checks (which refuse an over-instanced scene as 413 ``too-large`` without saying why)."""
    if (assembly or settings.assembly_default) != "split":
        return
    head = stream.read(20)
    try:
        if len(head) == 20 and head[:4] == b"glTF" and head[16:20] == b"JSON":
            length = int.from_bytes(head[12:16], "little")
            if length <= settings.max_upload_bytes:
                check_gltf_graph(head + stream.read(length))
    except InvalidShapeError as error:
        if error.reason == "assembly_too_large":
            raise invalid_shape_problem(error) from error
    finally:
        stream.seek(0)


def wants_split(settings: Settings, assembly: str | None, file_format: str) -> bool:
    """Whether an upload is split: asked (``split``), or not said and the default splits
    its format."""
    return assembly == "split" or (
        assembly is None and splits_by_default(settings, file_format))


def parts_of(settings: Settings, upload: CheckedUpload, assembly: str | None
             ) -> list[PartFile] | None:
    """The parts an upload becomes besides its own model; None when it stays one model (not
    split, or split by default but a file that places one part once)."""
    if not wants_split(settings, assembly, upload.format):
        return None
    parts = split_checked(settings, upload)
    return parts if assembly == "split" or is_assembly(parts) else None


def split_checked(settings: Settings, upload: CheckedUpload) -> list[PartFile]:
    """The parts of an upload that is split; a refusal as its Problem (422
    ``assembly-too-large`` for a bomb, or the reader's)."""
    try:
        return split_upload(settings, upload.content, upload.filename)
    except InvalidShapeError as error:
        raise invalid_shape_problem(error) from error
    except SandboxCrash as error:
        raise invalid_shape_problem(InvalidShapeError(
            "unparsable", f"the assembly could not be split: {error}")) from error


def _owned(connection: Connection, tenant: str, model_id: str) -> uuid.UUID:
    """The id of the tenant's model ``model_id``, or 404."""
    parsed = parse_model_id(model_id)
    found = None if parsed is None else connection.scalar(
        select(Model.id).where(Model.id == parsed, Model.tenant == tenant)
    )
    if found is None:
        raise model_not_found(model_id)
    return found


@router.get(
    "/models/{model_id}/parts",
    response_model=PartsResponse,
    responses=problem_responses(401, 404),
    summary="The parts of an assembly, with their counts and placements",
    description="For a model uploaded with `assembly=split`: each distinct part model "
    "once, with how many times the assembly places it and every placement. Empty for "
    "any other model.",
)
def model_parts(model_id: str, tenant: TenantDep, services: ServicesDep) -> PartsResponse:
    with services.reader.connect() as connection:
        assembly_id = _owned(connection, tenant, model_id)
        parts = assembly_parts(connection, tenant, assembly_id)
    return PartsResponse(
        assembly_id=assembly_id,
        parts=[PartUse(model=summary_of(row), count=len(placements), placements=placements)
               for row, placements in parts],
    )


@router.get(
    "/models/{model_id}/parts/points",
    response_model=PartPointsResponse,
    responses=problem_responses(401, 404, 409),
    summary="Points on an assembly, each with the part it lies on",
    description="What a viewer needs to highlight a part in its assembly: points on the "
    "whole assembly, each labelled with one of its parts (every placement of it). 409 "
    "`model-not-ready` until the assembly is described; a part not described yet labels "
    "nothing.",
)
def model_part_points(
    model_id: str, tenant: TenantDep, services: ServicesDep,
    points: Annotated[int, Query(ge=1, le=MAX_LABELLED_POINTS,
                                 description="At most this many points.")] = 2000,
) -> PartPointsResponse:
    with services.reader.connect() as connection:
        assembly_id = _owned(connection, tenant, model_id)
        found = labelled_points(connection, tenant, assembly_id, points)
        status = None if found is not None else connection.scalar(
            select(Model.status).where(Model.id == assembly_id))
    if found is None:
        raise Problem("model-not-ready",
                      f"Model {assembly_id} is {status}; its points come with its describe.",
                      model_status=status)
    return PartPointsResponse(
        assembly_id=assembly_id, part_ids=found.part_ids,
        points=found.points.round(6).tolist(), labels=found.labels.tolist(),
    )


@router.get(
    "/models/{model_id}/where-used",
    response_model=WhereUsedResponse,
    responses=problem_responses(401, 404),
    summary="The assemblies that contain a part",
    description="The assemblies that place this model, and those that place a part the "
    "index finds to be a copy of it (likeness `copy` and sizes within 3 %; decided when "
    "asked, so a part uploaded on its own or in another assembly is recognised), each with "
    "its count. Copies are only looked for once the model is ready.",
)
def model_where_used(
    model_id: str, tenant: TenantDep, services: ServicesDep
) -> WhereUsedResponse:
    with services.reader.connect() as connection:
        part_id = _owned(connection, tenant, model_id)
        used = where_used_entries(services, connection, tenant, part_id)
    return WhereUsedResponse(model_id=part_id, assemblies=used)


def where_used_entries(services: Services, connection: Connection, tenant: str,
                       model_id: uuid.UUID) -> list[WhereUsedEntry]:
    """``GET /v1/models/{id}/where-used``'s entries for one model."""
    return [WhereUsedEntry(assembly=summary_of(entry.assembly), count=entry.count,
                           parts=entry.parts)
            for entry in where_used(services.index, connection, tenant, model_id)]


def with_where_used(services: Services, tenant: str, answer: Any) -> Any:
    """A similar answer (plain values, ``app.api.answers.similar_body``) whose every result
    gains ``where_used``: the assemblies that contain it or a copy of it."""
    results = []
    with services.reader.connect() as connection:
        for result in answer["results"]:  # new dicts: the answer may be shared
            model_id = uuid.UUID(str(result["model"]["id"]))
            used = where_used_entries(services, connection, tenant, model_id)
            results.append({**result, "where_used": [entry.model_dump() for entry in used]})
    return {**answer, "results": results}
