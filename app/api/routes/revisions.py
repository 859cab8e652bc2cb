"""Models as a PLM system keeps them: upsert by external id, revisions, re-describe and the
stored original (``GET /v1/stats``, in ``app.api.routes.stats``, shows how far a re-describe
has come).

    PUT  /v1/models/by-external-id/{external_id}   create (201), same file (200), new file (202)
    GET  /v1/models/{id}/revisions                 newest first
    POST /v1/models/{id}/redescribe                a job over the stored original (202)
    GET  /v1/models/{id}/file                      the current original upload
"""

from __future__ import annotations

import uuid
from datetime import datetime
from typing import Annotated, Literal

from fastapi import APIRouter, Depends, File, Form, Path, Query, Response, UploadFile
from pydantic import BaseModel, Field
from sqlalchemy import select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session
from starlette.convertors import Convertor, register_url_convertor

from app.api.assembly_schemas import AssemblyField
from app.api.deps import ServicesDep, SessionDep
from app.api.inputs import (
    JSON_OBJECT_FIELD,
    METADATA_HELP,
    InputLimits,
    fields_once,
    invalid_input,
)
from app.api.lookups import load_model, parse_model_id
from app.api.problems import Problem, problem_responses
from app.api.routes.assemblies import parts_of, refuse_bomb
from app.api.schemas import FileInfo, JobResource, ModelResource, job_resource, model_resource
from app.api.search_params import UnitsField
from app.api.uploads import UPLOAD_FILE_HELP, BackgroundField, CheckedUpload
from app.auth.dependency import TenantDep
from app.db.models import Job, Model, ModelRevision, Upload, utcnow
from app.ingest.assemblies import add_parts
from app.ingest.revisions import (
    add_revision,
    create_model_rows,
    enqueue_redescribe,
    latest_jobs,
    lock_models,
)

__all__ = ["RevisionList", "RevisionResource", "router"]

router = APIRouter(prefix="/v1", tags=["models"])


class _AnyText(Convertor[str]):
    """A path parameter that is any text, slashes and line feeds included: an external id
    is the client's own text, and Starlette's ``path`` convertor stops at a line feed."""

    regex = r"[\s\S]*"

    def convert(self, value: str) -> str:
        return value

    def to_string(self, value: str) -> str:
        return value


register_url_convertor("anytext", _AnyText())

_MEDIA_TYPES = {
    "stl": "model/stl",
    "obj": "model/obj",
    "ply": "application/x-ply",
    "glb": "model/gltf-binary",
    "gltf": "model/gltf+json",
    "3mf": "model/3mf",
    "off": "application/x-off",
    "step": "model/step",
    "iges": "model/iges",
}


class RevisionResource(BaseModel):
    id: uuid.UUID
    number: int = Field(description="1 for the first file, then 2, 3, ...")
    status: Literal["pending", "current", "superseded", "failed"] = Field(
        description="current: the file the descriptor comes from; pending: being described."
    )
    file: FileInfo
    created_at: datetime


class RevisionList(BaseModel):
    items: list[RevisionResource] = Field(description="Newest first.")


def _revision_resource(revision: ModelRevision) -> RevisionResource:
    return RevisionResource(
        id=revision.id,
        number=revision.number,
        status=revision.status,  # type: ignore[arg-type]
        file=FileInfo(
            filename=revision.file_name,
            size=revision.file_size,
            sha256=revision.file_sha256,
            format=revision.file_format,
        ),
        created_at=revision.created_at,
    )


@router.put(
    "/models/by-external-id/{external_id:anytext}",
    response_model=ModelResource,
    status_code=200,
    responses={
        201: {"description": "Created, with its describe job", "model": ModelResource},
        202: {"description": "A new revision; its job is describing it", "model": ModelResource},
        **problem_responses(401, 413, 415, 422, 503),
    },
    summary="Create or update the model with this external id",
    dependencies=[Depends(fields_once)],
    description="Absent: created (201 + job). Present with the same file (sha256): only "
    "name and metadata change (200, no job). A new file: a new revision is described (202 + "
    "job) while the model keeps its id and its previous descriptor stays searchable; when "
    "the job completes the new descriptor replaces it atomically.",
)
def upsert_model(
    external_id: Annotated[str, Path(description="Your id; unique per tenant.",
                                     json_schema_extra={"minLength": 1})],
    response: Response,
    file: Annotated[UploadFile, File(description=UPLOAD_FILE_HELP)],
    tenant: TenantDep,
    services: ServicesDep,
    name: Annotated[str | None, Form()] = None,
    metadata: Annotated[
        str | None,
        Form(description=METADATA_HELP + " Absent: the metadata stay as they are.",
             json_schema_extra=JSON_OBJECT_FIELD),
    ] = None,
    units: UnitsField = None,
    background: BackgroundField = False,
    assembly: AssemblyField = None,
) -> ModelResource:
    limits = InputLimits.from_settings(services.settings)
    if not external_id:
        raise invalid_input("/external_id", "must not be empty")
    limits.text(external_id, "/external_id")
    limits.text(name, "/name")
    limits.text(file.filename, "/file/filename")
    meta = limits.metadata_text(metadata) if metadata is not None else None
    refuse_bomb(services.settings, file.file, assembly)  # issue 76: 422 at once
    upload = services.uploads.read(file.file, file.filename)
    parts = parts_of(services.settings, upload, assembly)
    for _ in range(2):  # a concurrent create of the same external id: the second pass updates
        try:
            with services.sessions.begin() as session:
                lock_models(session, Model.tenant == tenant, Model.external_id == external_id)
                model = session.scalar(
                    select(Model).where(Model.tenant == tenant, Model.external_id == external_id)
                )
                if model is None:
                    model = Model(
                        id=uuid.uuid4(), tenant=tenant, external_id=external_id, name=name,
                        meta=meta or {}, status="queued", file_name=upload.filename,
                        file_size=len(upload.content), file_sha256=upload.sha256,
                        file_format=upload.format, units=units,
                    )
                    job = create_model_rows(
                        session, model, upload.content, background=background
                    )
                    if parts is not None:  # issue 76
                        add_parts(session, model, parts, background=background)
                    response.status_code = 201
                    response.headers["Location"] = f"/v1/models/{model.id}"
                    return model_resource(model, job)
                if name is not None:
                    model.name = name
                if meta is not None:
                    model.meta = meta
                if units is not None:
                    model.units = units
                model.updated_at = utcnow()
                pending = _describe_if_new(session, model, upload, background=background)
                if parts is not None:  # the new part list replaces the old one at once
                    add_parts(session, model, parts, background=background, reuse=True)
                response.status_code = 200 if pending is None else 202
                session.flush()
                return model_resource(
                    model, pending or latest_jobs(session, [model.id]).get(model.id)
                )
        except IntegrityError:
            continue
    raise Problem("conflict", "The model changed concurrently; retry.")


def _describe_if_new(
    session: Session, model: Model, upload: CheckedUpload, *, background: bool
) -> Job | None:
    """A job for ``upload`` unless it is the model's current (or already pending) file."""
    sha256 = upload.sha256
    if sha256 == model.file_sha256:
        return None
    pending = session.scalar(
        select(ModelRevision)
        .where(ModelRevision.model_id == model.id, ModelRevision.status == "pending")
        .order_by(ModelRevision.number.desc())
        .limit(1)
    )
    if pending is not None and pending.file_sha256 == sha256:  # a retried PUT
        return latest_jobs(session, [model.id]).get(model.id)
    revision = add_revision(
        session,
        model.id,
        file_name=upload.filename,
        file_size=len(upload.content),
        file_sha256=sha256,
        file_format=upload.format,
        content=upload.content,
    )
    return enqueue_redescribe(session, model, revision, background=background)


@router.get(
    "/models/{model_id}/revisions",
    response_model=RevisionList,
    responses=problem_responses(401, 404),
    summary="The files a model has had, newest first",
)
def list_revisions(model_id: str, tenant: TenantDep, session: SessionDep) -> RevisionList:
    model = load_model(session, tenant, model_id)
    revisions = session.scalars(
        select(ModelRevision)
        .where(ModelRevision.model_id == model.id)
        .order_by(ModelRevision.number.desc())
    ).all()
    return RevisionList(items=[_revision_resource(r) for r in revisions])


@router.post(
    "/models/{model_id}/redescribe",
    status_code=202,
    response_model=JobResource,
    responses=problem_responses(401, 404),
    summary="Describe a model again from its stored original",
    description="With the service's current engine settings. A ready model stays ready and "
    "searchable with its previous descriptor until the new one replaces it.",
)
def redescribe_model(
    model_id: str,
    response: Response,
    tenant: TenantDep,
    services: ServicesDep,
    background: Annotated[bool, Query(
        description="true for one of many re-describes sent together (a PLM system "
        "re-describing a product line): its job takes turns with the tenant's uploads "
        "instead of holding them up, as `shapesearch redescribe` does. Scheduling only."
    )] = False,
) -> JobResource:
    with services.sessions.begin() as session:
        lock_models(session, Model.id == parse_model_id(model_id), Model.tenant == tenant)
        model = load_model(session, tenant, model_id)
        job = enqueue_redescribe(session, model, background=background)
        resource = job_resource(job)
    response.headers["Location"] = f"/v1/jobs/{resource.id}"
    return resource


@router.get(
    "/models/{model_id}/file",
    response_class=Response,
    responses={
        200: {"description": "The original upload", "content": {"application/octet-stream": {}}},
        **problem_responses(401, 404),
    },
    summary="The stored original upload of the current revision",
)
def get_model_file(model_id: str, tenant: TenantDep, session: SessionDep) -> Response:
    model = load_model(session, tenant, model_id)
    content = session.scalar(select(Upload.content).where(Upload.model_id == model.id))
    if content is None:
        raise Problem("model-not-found", f"Model {model.id} has no stored file.")
    filename = model.file_name.replace('"', "").replace("\\", "")
    return Response(
        bytes(content),
        media_type=_MEDIA_TYPES.get(model.file_format, "application/octet-stream"),
        headers={"Content-Disposition": f'attachment; filename="{filename}"'},
    )
