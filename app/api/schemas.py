"""Request and response bodies of the v1 API, and their construction from table rows."""

from __future__ import annotations

import uuid
from collections.abc import Iterable
from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from app.api.inputs import METADATA_HELP, METADATA_SCHEMA
from app.db.models import Job, Model
from app.search.similarity import Candidate
from core.cutoff import CutoffRecord
from core.io import SUPPORTED_FORMATS
from core.rank.score_calibration import calibration_for

__all__ = [
    "FileInfo",
    "Health",
    "JobResource",
    "JobSummary",
    "ModelError",
    "ModelList",
    "ModelPatch",
    "ModelResource",
    "ModelSummary",
    "Size",
    "SearchQuery",
    "SearchResponse",
    "SimilarQuery",
    "SimilarResponse",
    "SimilarResult",
    "cutoff_record",
    "job_resource",
    "job_summary",
    "model_resource",
    "model_summary",
    "size_of",
]

ModelStatus = Literal["queued", "processing", "ready", "failed"]


class ModelError(BaseModel):
    """Why a model failed: a problem type, a title and a detail a user can act on."""

    type: str
    title: str
    detail: str


class FileInfo(BaseModel):
    filename: str
    size: int = Field(description="Bytes.")
    sha256: str
    format: str = Field(
        description="Detected file format, one of " + ", ".join(SUPPORTED_FORMATS) + "."
    )


class Size(BaseModel):
    """A model's size in the units of its file (``units``; null: not declared, compared as
    given): the sorted extents of its minimum-volume oriented bounding box, its surface
    area, and the volume it encloses when it is a watertight mesh (null otherwise)."""

    length: float
    width: float
    height: float
    area: float
    volume: float | None
    units: Literal["mm", "cm", "m", "in"] | None


class JobSummary(BaseModel):
    """The latest job of a model; GET /v1/jobs/{id} has the rest."""

    id: uuid.UUID
    status: Literal["queued", "running", "done", "failed"]
    attempts: int
    created_at: datetime
    updated_at: datetime


class ModelResource(BaseModel):
    id: uuid.UUID
    external_id: str | None
    name: str | None
    metadata: dict[str, Any]
    status: ModelStatus
    error: ModelError | None
    file: FileInfo
    n_points: int | None
    size: Size | None = Field(description="Null until described (and for models described "
                              "before sizes were measured: re-describe them).")
    cutoff: CutoffRecord | None
    descriptor_version: str | None
    timings: dict[str, float] | None = Field(description="Seconds per stage of the description.")
    created_at: datetime
    updated_at: datetime
    job: JobSummary | None = Field(default=None, description="The model's latest job.")


class ModelList(BaseModel):
    items: list[ModelResource]
    next_cursor: str | None = Field(description="Pass as `cursor` for the next page; null: last.")


class ModelPatch(BaseModel):
    """Fields to change; absent fields stay as they are."""

    model_config = ConfigDict(extra="forbid")

    name: str | None = Field(default=None, description="null clears the name.")
    # Not nullable, in the schema as in behaviour: send {} to clear the metadata.
    metadata: dict[str, Any] = Field(
        default_factory=dict,
        description="Replaces the metadata; {} clears it. " + METADATA_HELP,
        json_schema_extra=METADATA_SCHEMA,
    )


class ModelSummary(BaseModel):
    id: uuid.UUID
    external_id: str | None
    name: str | None
    metadata: dict[str, Any]
    size: Size | None


class SimilarResult(BaseModel):
    model: ModelSummary
    distance: float = Field(description="L2 distance between the unit descriptors, in [0, 2].")
    score: float = Field(description="1 - distance^2 / 4, in [0, 1]; 1 for identical descriptors "
                         "(the plain similarity, also where the hub discount and its re-rank "
                         "order the results).")
    calibrated_score: float | None = Field(
        default=None,
        description="The share of pairs of different kinds of part (measured on the tuning "
        "sources) that score lower than this one: 0.99 means 1 % of different-kind pairs "
        "score as high. A threshold on it is a false-match rate (README, What a score "
        "means). Null for a descriptor layout without a calibration.",
    )


def similar_results(matches: Iterable[Any], descriptor_version: str) -> list[SimilarResult]:
    """The answer's results from ``app.search.similarity.Match``es of one descriptor_version."""
    calibration = calibration_for(descriptor_version)
    return [
        SimilarResult(
            model=model_summary(m.model),
            distance=m.distance,
            score=m.score,
            calibrated_score=None if calibration is None else calibration(m.score),
        )
        for m in matches
    ]


class SimilarQuery(BaseModel):
    model_id: uuid.UUID


class SimilarResponse(BaseModel):
    query: SimilarQuery
    results: list[SimilarResult] = Field(
        description="Best first: in shape mode with the hub discount and its k-reciprocal "
        "re-rank (see the endpoint).")


class SearchQuery(BaseModel):
    """The uploaded scan as described for the search (nothing is stored)."""

    n_points: int
    cutoff: CutoffRecord
    descriptor_version: str
    format: str
    size: Size | None = Field(description="As measured on the upload (a partial scan "
                              "under-measures), in the units given with it.")


class SearchResponse(BaseModel):
    query: SearchQuery
    results: list[SimilarResult] = Field(
        description="Best first: in shape mode with the hub discount and its k-reciprocal "
        "re-rank (see the endpoint).")


class JobResource(BaseModel):
    id: uuid.UUID
    kind: Literal["describe", "redescribe", "duplicates"] = Field(
        description="describe: a new model's file; redescribe: a model's stored or new file "
        "again; duplicates: the tenant's duplicates report (GET /v1/duplicates once done)."
    )
    model_id: uuid.UUID | None = Field(description="The model described; null for a "
                                       "duplicates job.")
    status: Literal["queued", "running", "done", "failed"]
    background: bool = Field(description="Part of a bulk load (an upload sent with "
                             "background=true) or of a catalogue's re-describe: it takes "
                             "turns with the tenant's other jobs instead of holding them up.")
    attempts: int
    last_error: ModelError | None
    leased_until: datetime | None
    created_at: datetime
    updated_at: datetime


class Health(BaseModel):
    status: str
    checks: dict[str, str] | None = None


def cutoff_record(stored: dict[str, Any] | None) -> CutoffRecord | None:
    """A model's stored cutoff (``Model.cutoff``) as the API shows it."""
    return CutoffRecord.from_json(stored) if stored else None


def job_summary(job: Job) -> JobSummary:
    return JobSummary(
        id=job.id,
        status=job.status,  # type: ignore[arg-type]
        attempts=job.attempts,
        created_at=job.created_at,
        updated_at=job.updated_at,
    )


def model_resource(model: Model, job: Job | None = None) -> ModelResource:
    return ModelResource(
        id=model.id,
        external_id=model.external_id,
        name=model.name,
        metadata=model.meta or {},
        status=model.status,  # type: ignore[arg-type]
        error=ModelError(**model.error) if model.error else None,
        file=FileInfo(
            filename=model.file_name,
            size=model.file_size,
            sha256=model.file_sha256,
            format=model.file_format,
        ),
        n_points=model.n_points,
        size=size_of(model.size_length, model.size_width, model.size_height, model.size_area,
                     model.size_volume, model.units),
        cutoff=cutoff_record(model.cutoff),
        descriptor_version=model.descriptor_version,
        timings=model.timings,
        created_at=model.created_at,
        updated_at=model.updated_at,
        job=job_summary(job) if job is not None else None,
    )


def model_summary(model: Candidate) -> ModelSummary:
    shape = model.size
    size = None if shape is None else size_of(
        shape.length, shape.width, shape.height, shape.area, shape.volume, model.units
    )
    return ModelSummary(
        id=model.id, external_id=model.external_id, name=model.name, metadata=model.meta or {},
        size=size,
    )


def size_of(
    length: float | None, width: float | None, height: float | None, area: float | None,
    volume: float | None, units: str | None,
) -> Size | None:
    """The ``Size`` of stored size columns (None when the model has none)."""
    if length is None or width is None or height is None or area is None:
        return None
    return Size(length=length, width=width, height=height, area=area, volume=volume,
                units=units)  # type: ignore[arg-type]


def job_resource(job: Job) -> JobResource:
    return JobResource(
        id=job.id,
        kind=job.kind,  # type: ignore[arg-type]
        model_id=job.model_id,
        status=job.status,  # type: ignore[arg-type]
        background=job.background,
        attempts=job.attempts,
        last_error=ModelError(**job.last_error) if job.last_error else None,
        leased_until=job.leased_until,
        created_at=job.created_at,
        updated_at=job.updated_at,
    )
