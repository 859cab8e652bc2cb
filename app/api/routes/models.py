"""/v1/models: upload, read, list, change and delete models; /v1/models/{id}/similar."""

from __future__ import annotations

import asyncio
import functools
import uuid
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Annotated, Any

import numpy as np
from fastapi import APIRouter, Depends, File, Form, Header, Query, Request, Response, UploadFile
from fastapi.responses import JSONResponse
from sqlalchemy import (
    Connection,
    Engine,
    Row,
    Select,
    Text,
    and_,
    bindparam,
    delete,
    or_,
    select,
    type_coerce,
    update,
)
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session, aliased

from app.api.answers import (
    JOB_COLUMNS,
    JSON,
    MODEL_COLUMNS,
    STORED_JSON,
    STORED_TIMES,
    STORED_UUIDS,
    json_body,
    json_response,
    model_fields,
    similar_body,
    stored_fields,
)
from app.api.assembly_schemas import AssemblyField
from app.api.cursors import KeysetCursor, encode_keyset, keyset_after
from app.api.deps import Services, ServicesDep, SessionDep
from app.api.idempotency import remember, replay_or_refuse, request_sha256
from app.api.inputs import JSON_OBJECT_FIELD, METADATA_HELP, InputLimits, fields_once
from app.api.lookups import load_model, model_not_found, parse_model_id
from app.api.problems import Problem, problem_responses
from app.api.routes.assemblies import parts_of, refuse_bomb, wants_split, with_where_used
from app.api.schemas import (
    ModelList,
    ModelPatch,
    ModelResource,
    ModelStatus,
    SimilarResponse,
    model_resource,
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
    size_options,
)
from app.api.uploads import UPLOAD_FILE_HELP, BackgroundField
from app.auth.dependency import TenantDep
from app.db.feed import record_event
from app.db.models import AssemblyPart, Job, Model, utcnow
from app.ingest.assemblies import add_parts
from app.ingest.revisions import create_model_rows, latest_jobs, lock_models
from app.search.similarity import Match, QueryChanged, SearchMode, find_similar
from app.search.sizing import extents_mm
from app.webhooks import record_model_event

__all__ = ["router"]

router = APIRouter(prefix="/v1", tags=["models"])

def _duplicate(session: Session, tenant: str, external_id: str) -> Problem | None:
    existing = session.scalar(
        select(Model.id).where(Model.tenant == tenant, Model.external_id == external_id)
    )
    if existing is None:
        return None
    return Problem(
        "duplicate-external-id",
        f"external_id {external_id!r} is already used by model {existing}.",
        existing_id=str(existing),
    )


@router.post(
    "/models",
    status_code=202,
    response_model=ModelResource,
    responses=problem_responses(401, 409, 413, 415, 422, 503),
    summary="Upload a part; it is described in the background",
    dependencies=[Depends(fields_once)],
)
def upload_model(
    request: Request,
    response: Response,
    file: Annotated[UploadFile, File(description=UPLOAD_FILE_HELP)],
    tenant: TenantDep,
    services: ServicesDep,
    external_id: Annotated[str | None, Form(description="Your id; unique per tenant.")] = None,
    name: Annotated[str | None, Form()] = None,
    metadata: Annotated[
        str | None, Form(description=METADATA_HELP, json_schema_extra=JSON_OBJECT_FIELD)
    ] = None,
    units: UnitsField = None,
    background: BackgroundField = False,
    assembly: AssemblyField = None,
    idempotency_key: Annotated[
        str | None,
        Header(
            max_length=300,
            description="Retries with the same key and body get the "
            "first answer back; another body with the same key gets 422.",
        ),
    ] = None,
) -> ModelResource | JSONResponse:
    limits = InputLimits.from_settings(services.settings)
    limits.text(external_id, "/external_id")
    limits.text(name, "/name")
    limits.text(file.filename, "/file/filename")
    meta = limits.metadata_text(metadata)
    refuse_bomb(services.settings, file.file, assembly)  # issue 76: 422 at once
    upload = services.uploads.read(file.file, file.filename)
    split = wants_split(services.settings, assembly, upload.format)
    request_digest = request_sha256(upload.sha256 + (":split" if split else ""), external_id,
                                    name, meta, units, background)
    if idempotency_key is not None:
        replay = replay_or_refuse(services.sessions, tenant, idempotency_key, request_digest,
                                  services.settings.idempotency_ttl_seconds)
        if replay is not None:
            return replay
    parts = parts_of(services.settings, upload, assembly)
    model = Model(
        id=uuid.uuid4(),
        tenant=tenant,
        external_id=external_id,
        name=name,
        meta=meta,
        status="queued",
        file_name=upload.filename,
        file_size=len(upload.content),
        file_sha256=upload.sha256,
        file_format=upload.format,
        units=units,
    )
    try:
        # The model, its bytes and its job commit together: no accepted upload without a job.
        with services.sessions.begin() as session:
            job = create_model_rows(session, model, upload.content, background=background)
            if parts is not None:  # issue 76: its parts as models, with their placements
                add_parts(session, model, parts, background=background)
            resource = model_resource(model, job)
            if idempotency_key is not None:
                remember(session, tenant, idempotency_key, request_digest, 202, resource,
                         services.settings.idempotency_ttl_seconds)
    except IntegrityError as error:  # unique (tenant, external_id) or the idempotency key
        if idempotency_key is not None:
            replay = replay_or_refuse(services.sessions, tenant, idempotency_key, request_digest,
                                      services.settings.idempotency_ttl_seconds)
            if replay is not None:
                return replay
        with services.sessions() as session:
            problem = _duplicate(session, tenant, external_id) if external_id else None
        if problem is None:
            raise
        raise problem from error
    response.headers["Location"] = f"/v1/models/{model.id}"
    return resource


@router.get(
    "/models",
    response_model=ModelList,
    responses=problem_responses(401, 422),
    summary="List models, newest first",
)
async def list_models(
    tenant: TenantDep,
    services: ServicesDep,
    status: ModelStatus | None = None,
    external_id: str | None = None,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
    cursor: KeysetCursor = "",
    assembly_id: AssemblyQuery = None,
) -> Response:
    # Like similar: one hop to the query pool for the whole page (a sync route and its
    # session dependency took three hops of the framework's 40-thread pool, whose threads
    # then contend for the GIL under load).
    kind, values = page_query(tenant, status, external_id, keyset_after(cursor), limit,
                              assembly_id)
    body = await asyncio.get_running_loop().run_in_executor(
        services.queries, page_json, services.reader, kind, values, limit
    )
    return Response(body, media_type=JSON)


def page_query(tenant: str, status: str | None, external_id: str | None,
               after: tuple[datetime, uuid.UUID] | None, limit: int,
               assembly_id: uuid.UUID | None = None
               ) -> tuple[tuple[bool, bool, bool, bool], dict[str, Any]]:
    """What a catalogue page asks: which filters (``_page_statement``'s kind) and the values
    they and its statement bind."""
    values: dict[str, Any] = {"tenant": tenant, "limit": limit + 1}
    if status is not None:
        values["status"] = status
    if external_id is not None:
        values["external_id"] = external_id
    if after is not None:
        values["created_at"], values["model_id"] = after
    if assembly_id is not None:
        values["assembly_id"] = assembly_id
    return (status is not None, external_id is not None, after is not None,
            assembly_id is not None), values


@functools.lru_cache(maxsize=32)
def _page_statement(stored: bool, by_status: bool, by_external_id: bool,
                    after: bool, by_assembly: bool) -> Select[Any]:
    """One statement for a whole page: the columns a ``ModelResource`` shows, each model with
    its latest job (``latest_jobs``' choice: the last by ``created_at``, then ``id``); the
    values are bound (``tenant``, ``limit``, and ``status``, ``external_id``,
    ``created_at``, ``model_id`` and ``assembly_id`` as asked), so it is built once per kind
    of page.
    ``stored``: the ``STORED_*`` columns read as the text SQLite stores
    (``app.api.answers.stored_fields``)."""
    job = aliased(Job)
    latest = (
        select(Job.id).where(Job.model_id == Model.id)
        .order_by(Job.created_at.desc(), Job.id.desc()).limit(1).scalar_subquery()
    )
    query = (
        select(*(_column(Model, name, stored) for name in MODEL_COLUMNS),
               *(_column(job, name, stored) for name in JOB_COLUMNS))
        .outerjoin(job, job.id == latest)
        .where(Model.tenant == bindparam("tenant"))
    )
    if by_status:
        query = query.where(Model.status == bindparam("status"))
    if by_external_id:
        query = query.where(Model.external_id == bindparam("external_id"))
    if by_assembly:  # the parts an assembly places (issue 76)
        query = query.where(Model.id.in_(
            select(AssemblyPart.part_id).where(AssemblyPart.assembly_id == bindparam(
                "assembly_id", type_=AssemblyPart.assembly_id.type))))
    if after:
        # Keyset pagination on (created_at, id): stable while models come and go.
        query = query.where(
            or_(
                Model.created_at < bindparam("created_at"),
                and_(Model.created_at == bindparam("created_at"),
                     Model.id < bindparam("model_id")),
            )
        )
    return query.order_by(Model.created_at.desc(), Model.id.desc()).limit(bindparam("limit"))


def _column(entity: Any, name: str, stored: bool) -> Any:
    column = getattr(entity, name)
    if stored and name in STORED_UUIDS | STORED_JSON | STORED_TIMES:
        return type_coerce(column, Text)  # the same SQL; the value as stored
    return column


def page_json(reader: Engine, kind: tuple[bool, bool, bool, bool], values: dict[str, Any],
              limit: int) -> bytes:
    """``model_page`` encoded (in the query pool: the event loop only sends it)."""
    return json_body(model_page(reader, kind, values, limit))


def model_page(reader: Engine, kind: tuple[bool, bool, bool, bool], values: dict[str, Any],
               limit: int) -> dict[str, Any]:
    """A ``ModelList`` as plain values (``app.api.answers``) of the page ``page_query``
    describes."""
    stored = reader.dialect.name == "sqlite"
    with reader.connect() as connection:
        rows = connection.execute(_page_statement(stored, *kind), values).all()
    models = len(MODEL_COLUMNS)
    page = rows[:limit]
    fields = stored_fields if stored else model_fields
    items = [fields(row[:models], None if row[models] is None else row[models:])
             for row in page]
    next_cursor = None
    if len(rows) > limit and page:
        model_id, created_at = page[-1][0], page[-1][MODEL_COLUMNS.index("created_at")]
        if stored:
            model_id = uuid.UUID(model_id)
            created_at = datetime.fromisoformat(created_at).replace(tzinfo=UTC)
        next_cursor = encode_keyset(_Keyed(model_id, created_at))
    return {"items": items, "next_cursor": next_cursor}


@dataclass
class _Keyed:
    """What ``encode_keyset`` reads of a page's last row."""

    id: uuid.UUID
    created_at: datetime


@router.get(
    "/models/{model_id}",
    response_model=ModelResource,
    responses=problem_responses(401, 404),
    summary="One model",
)
def get_model(
    model_id: str,
    tenant: TenantDep,
    session: SessionDep,
) -> ModelResource:
    model = load_model(session, tenant, model_id)
    return model_resource(model, latest_jobs(session, [model.id]).get(model.id))


@router.patch(
    "/models/{model_id}",
    response_model=ModelResource,
    responses=problem_responses(401, 404, 422),
    summary="Change the name or the metadata",
)
def patch_model(
    model_id: str,
    patch: ModelPatch,
    tenant: TenantDep,
    services: ServicesDep,
) -> ModelResource:
    limits = InputLimits.from_settings(services.settings)
    changes: dict[str, Any] = {"updated_at": utcnow()}
    if "name" in patch.model_fields_set:
        changes["name"] = limits.text(patch.name, "/name")
    if "metadata" in patch.model_fields_set:
        changes["meta"] = limits.metadata(patch.metadata)
    model_uuid = parse_model_id(model_id)
    with services.sessions.begin() as session:
        model = session.scalar(
            update(Model)
            .where(Model.id == model_uuid, Model.tenant == tenant)
            .values(**changes)
            .returning(Model)
        )
        if model is None:
            raise model_not_found(model_id)
        return model_resource(model, latest_jobs(session, [model.id]).get(model.id))


@router.delete(
    "/models/{model_id}",
    status_code=204,
    response_class=Response,
    responses=problem_responses(401, 404),
    summary="Delete a model; it leaves search results at once",
)
def delete_model(
    model_id: str,
    tenant: TenantDep,
    services: ServicesDep,
) -> Response:
    model_uuid = parse_model_id(model_id)
    with services.sessions.begin() as session:
        if model_uuid is not None and lock_models(
            session, Model.id == model_uuid, Model.tenant == tenant
        ):
            record_model_event(session, model_uuid, "model.deleted")  # commits with the delete
        # The upload and the job go with it (ON DELETE CASCADE).
        index_id = session.scalar(
            delete(Model)
            .where(Model.id == model_uuid, Model.tenant == tenant)
            .returning(Model.index_id)
        )
        if index_id is None:
            raise model_not_found(model_id)
        record_event(session, index_id, "deleted", tenant)  # other processes follow the feed
    services.index.remove(index_id)  # this process: at once
    return Response(status_code=204)


@router.get(
    "/models/{model_id}/similar",
    response_model=SimilarResponse,
    responses=problem_responses(401, 404, 409, 422),
    summary="The models most similar to a ready model",
    openapi_extra=FILTER_PARAMETERS,
    description="Best first, the model itself left out. Filter on metadata with query "
    "parameters `metadata.KEY=VALUE` (string values compare as text, others by their JSON "
    "form, e.g. `metadata.qty=3`); filters apply before the top-k cut. "
    "score = 1 - distance^2/4 for unit descriptors: 1 identical, 0 opposite. "
    + SCAN_MODE_HELP + " Use mode=scan for a model that was uploaded as a partial scan (a "
    "model described before scan mode existed is then queried with its plain descriptor)."
    + ORDER_HELP + SIZE_HELP,
)
async def similar_models(
    model_id: str,
    filters: Annotated[dict[str, str], Depends(metadata_filters)],
    ranges: Annotated[dict[str, tuple[float | None, float | None]], Depends(metadata_ranges)],
    size: Annotated[SizeOptions, Depends(size_options)],
    tenant: TenantDep,
    services: ServicesDep,
    k: Annotated[int, Query(ge=1, le=100)] = 10,
    min_score: Annotated[float | None, Query(ge=0, le=1)] = None,
    mode: ModeQuery = "shape",
    where_used: Annotated[bool, Query(
        description="true: each result also lists `where_used`, the assemblies that "
        "contain it or a copy of it (as `GET /v1/models/{id}/where-used`).")] = False,
    assembly_id: AssemblyQuery = None,
) -> Response:
    # One hop for the whole query (database and FAISS) to a small pool of its own: the
    # event loop is never blocked, and a few threads per core contend less for the GIL
    # than one per concurrent request would. The index is kept in step by the
    # background sync, not polled per request.
    loop = asyncio.get_running_loop()
    if not where_used:  # encoded in the query pool too: the event loop only sends it
        body = await loop.run_in_executor(
            services.queries, similar_json, services, tenant, model_id, k, min_score, filters,
            ranges, mode, size, assembly_id,
        )
        return Response(body, media_type=JSON)
    answer = await loop.run_in_executor(
        services.queries, similar_answer, services, tenant, model_id, k, min_score, filters,
        ranges, mode, size, assembly_id,
    )
    answer = await loop.run_in_executor(  # issue 76
        services.queries, with_where_used, services, tenant, answer
    )
    return json_response(answer)


def ready_query(
    connection: Connection, tenant: str, model_id: str, mode: SearchMode = "shape"
) -> Row[Any]:
    """The ``id, index_id, descriptor, descriptor_version`` (and in scan mode
    ``scan_descriptor``) of the tenant's ready model ``model_id``: only what a similarity
    query needs, not the whole row; 404 or 409."""
    parsed = parse_model_id(model_id)
    model: Any = None
    if parsed is not None:
        model = connection.execute(
            select(
                Model.id,
                Model.index_id,
                Model.status,
                Model.descriptor,
                Model.descriptor_version,
                Model.size_length,
                Model.size_width,
                Model.size_height,
                Model.units,
                *([Model.scan_descriptor] if mode == "scan" else []),
            ).where(Model.id == parsed, Model.tenant == tenant)
        ).one_or_none()
    if model is None:
        raise model_not_found(model_id)
    if model.status != "ready" or model.descriptor is None or model.descriptor_version is None:
        raise Problem(
            "model-not-ready",
            f"Model {model.id} is {model.status}; similarity needs a ready model.",
            model_status=model.status,
        )
    return model


def similar_json(*arguments: Any) -> bytes:
    """``similar_answer(*arguments)`` encoded (in the query pool: the event loop only sends
    it)."""
    return json_body(similar_answer(*arguments))


def similar_answer(
    services: Services,
    tenant: str,
    model_id: str,
    k: int,
    min_score: float | None,
    filters: dict[str, str],
    ranges: dict[str, tuple[float | None, float | None]],
    mode: SearchMode,
    size: SizeOptions,
    assembly_id: uuid.UUID | None = None,
) -> Any:
    """A ``SimilarResponse`` as plain values (``app.api.answers.similar_body``)."""
    options: dict[str, Any] = {
        "k": k,
        "min_score": min_score,
        "filters": filters,
        "metadata_ranges": ranges,
        "pushdown_max": services.settings.filter_pushdown_max,
        "mode": mode,
        "assembly_id": assembly_id,
    }
    with services.reader.connect() as connection:
        if not size.needs_query_size:  # else the query model's size is read with its row
            options["size"] = size.query(None)
            found = _similar_by_index(services, connection, tenant, model_id, mode, options)
            if found is not None:
                return found
        model = ready_query(connection, tenant, model_id, mode)
        options["size"] = size.query(
            extents_mm(model.size_length, model.size_width, model.size_height, model.units)
        )
        query = (model.scan_descriptor if mode == "scan" else None) or model.descriptor
        vector = np.frombuffer(query, dtype=np.float32)
        key = (tenant, model.descriptor_version)
        matches = find_similar(
            services.index, connection, key, vector, exclude=model.index_id, **options
        )
        return _similar_response(model.id, matches, model.descriptor_version)



def _similar_by_index(
    services: Services,
    connection: Connection,
    tenant: str,
    model_id: str,
    mode: SearchMode,
    options: dict[str, Any],
) -> Any:
    """The answer with the query vector taken from the index and the query model's row
    confirmed with the candidates': one statement instead of two. None when this path does
    not apply (scan mode's own descriptor, a model the index does not hold) or the model
    changed since the index saw it: then the database decides, with its 404 or 409."""
    parsed = parse_model_id(model_id)
    if parsed is None or mode != "shape":
        return None
    located = services.index.locate(tenant, parsed)
    if located is None:
        return None
    index_id, key = located
    vector = services.index.vector(key, index_id)
    if vector is None:
        return None
    try:
        matches = find_similar(
            services.index,
            connection,
            key,
            vector,
            exclude=index_id,
            indexed_query=True,
            **options,
        )
    except QueryChanged:
        return None
    return _similar_response(parsed, matches, key[1])


def _similar_response(model_id: uuid.UUID, matches: list[Match], descriptor_version: str) -> Any:
    return similar_body(model_id, matches, descriptor_version)
