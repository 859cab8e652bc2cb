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
from core.rank.score_calibration import Likeness, calibration_for, in_words

__all__ = [
    "AlignmentRecord",
    "CompareResponse",
    "ComparePoints",
    "DeviationFigures",
    "Explanation",
    "Extents",
    "FileInfo",
    "Health",
    "JobResource",
    "JobSummary",
    "ModelError",
    "ModelList",
    "ModelPatch",
    "ModelResource",
    "ModelSummary",
    "PointSet",
    "PointsSources",
    "Size",
    "SearchQuery",
    "SearchResponse",
    "SearchResult",
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


class WhereUsedEntry(BaseModel):
    """One assembly that uses a part (issue 76, ``app.api.routes.assemblies``)."""

    assembly: ModelSummary = Field(description="An assembly that contains the part.")
    count: int = Field(description="How many times it places the part (or its copies).")
    parts: list[uuid.UUID] = Field(
        description="The part models of that assembly that matched: the part itself, or "
        "parts the index finds to be copies of it (likeness `copy`, sizes within 3 %).",
    )


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
    likeness: Likeness | None = Field(
        default=None,
        description="The calibrated score in words: \"copy\" from 0.995 (at most 0.5 % of "
        "different-kind pairs score as high; about 95 % of re-sampled copies and 40 % of "
        "same-kind pairs do), \"same kind\" from 0.95 (5 %; about 70 % of same-kind pairs), "
        "\"different kind\" below. Words for reading, not proof: a copy at another size and "
        "a same-kind part of the same proportions read alike (compare sizes, or "
        "/v1/models/{id}/compare/{other_id}). Null without a calibration.",
    )
    # Only in a similar answer asked with where_used=true (absent otherwise, not null).
    where_used: list[WhereUsedEntry] | None = Field(
        default=None,
        exclude_if=lambda value: value is None,
        description="With `where_used=true` only: the assemblies that contain this model "
        "or a copy of it, as `GET /v1/models/{id}/where-used` answers.",
    )


def similar_results(matches: Iterable[Any], descriptor_version: str) -> list[SimilarResult]:
    """The answer's results from ``app.search.similarity.Match``es of one descriptor_version."""
    calibration = calibration_for(descriptor_version)
    results = []
    for m in matches:
        calibrated = None if calibration is None else calibration(m.score)
        results.append(SimilarResult(
            model=model_summary(m.model),
            distance=m.distance,
            score=m.score,
            calibrated_score=calibrated,
            likeness=None if calibrated is None else in_words(calibrated),
        ))
    return results


class SimilarQuery(BaseModel):
    model_id: uuid.UUID


class SimilarResponse(BaseModel):
    query: SimilarQuery
    results: list[SimilarResult] = Field(
        description="Best first: in shape mode with the hub discount and its k-reciprocal "
        "re-rank (see the endpoint).")


class AlignmentRecord(BaseModel):
    """A rigid placement (with a uniform scale) of one point set on another: a point ``p``
    of the placed part lands at ``scale * rotation @ p + translation``."""

    rotation: list[list[float]] = Field(
        description="3 x 3, row-major, a proper rotation (determinant +1).",
        min_length=3, max_length=3)
    translation: list[float] = Field(description="3 numbers, in the reference's units.",
                                     min_length=3, max_length=3)
    scale: float = Field(description="1 unless a scale was asked for (or, for a scan, "
                         "found: the scan's units are unknown).")
    candidates: int = Field(description="Starts tried: the principal frames' ambiguities "
                            "(and, for a scan, the views of the part), each refined by ICP; "
                            "the best result is kept.")


class DeviationFigures(BaseModel):
    """How far one part's points lie from the other part's surface (its sample points, each
    taken as the small disc of surface it stands for), in the reference's units."""

    rms: float
    mean: float
    p95: float = Field(description="95th percentile.")
    max: float
    within: float = Field(description="Share of the points within `tolerance`, in [0, 1].")


class PointSet(BaseModel):
    positions: list[list[float]] = Field(description="Points [x, y, z] in the reference's "
                                         "frame and units.")
    deviations: list[float] = Field(description="Each point's distance from the other part, "
                                    "in the reference's units.")


class ComparePoints(BaseModel):
    """Sample points of both parts, aligned, each with its deviation (for colouring)."""

    model: PointSet = Field(description="The reference part's points.")
    other: PointSet = Field(description="The placed part's (or scan's) points, aligned.")


class Explanation(BaseModel):
    """The scan placed on this result: its alignment at the part's scale, how close it lies
    and how much of the part it covers."""

    alignment: AlignmentRecord = Field(description="The scan onto the part (the scan's units "
                                       "are unknown, so with a scale).")
    rms: float = Field(description="RMS distance of the scan's points from the part's "
                       "surface, in the part's units.")
    coverage: float = Field(description="Share of the part's sample points within "
                            "`tolerance` of the aligned scan: about half for one view of a "
                            "closed part, near 1 for a full scan.")
    tolerance: float = Field(description="1 % of the larger bounding-box diagonal, in the "
                             "part's units.")
    view: int | None = Field(description="In scan mode, the part's virtual view whose "
                             "descriptor matched (0-based); null: its whole descriptor (and "
                             "always in shape mode).")
    points_source: Literal["sample", "preview"] = Field(
        description="The part's points: its stored sample, or (described before samples "
        "were kept) its preview scaled back to its units.")
    points: ComparePoints | None = Field(
        default=None, description="With `points=N`: up to N points of the part (model) and of "
        "the aligned scan (other) with their deviations.")


class SearchResult(SimilarResult):
    explanation: Explanation | None = Field(
        default=None, description="With `explain=true`, for the first few results (see the "
        "endpoint); null otherwise, and for a part placed past its time budget.")


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
    results: list[SearchResult] = Field(
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


class Extents(BaseModel):
    model: list[float] = Field(min_length=3, max_length=3)
    other: list[float] = Field(min_length=3, max_length=3)


class PointsSources(BaseModel):
    """Each part's points: its stored sample (the description's points in its file's units),
    or, for a model described before samples were kept, its preview's 2000 points scaled
    back by the square root of its surface area (centred: the translation is then relative
    to its centre). Re-describe a model to get its sample."""

    model: Literal["sample", "preview"]
    other: Literal["sample", "preview"]


class CompareResponse(BaseModel):
    """``other`` placed on ``model``, and how far apart they are, in ``model``'s units."""

    model: ModelSummary
    other: ModelSummary
    units: Literal["mm", "cm", "m", "in"] | None = Field(
        description="The units of every length here: the model's (null: not declared; "
        "the other's points are converted when both declare theirs, else compared as "
        "given).")
    alignment: AlignmentRecord = Field(description="`other` onto `model`.")
    tolerance: float
    model_to_other: DeviationFigures = Field(description="Each of the model's points from "
                                             "the other part.")
    other_to_model: DeviationFigures = Field(description="Each of the other part's points "
                                             "from the model.")
    size_ratios: list[float] = Field(
        description="The other part's extents over the model's, along the model's principal "
        "axes (largest spread first): 1.1 = 10 % longer.", min_length=3, max_length=3)
    extents: Extents = Field(description="Both parts' extents along the model's principal "
                             "axes, in its units.")
    points_source: PointsSources
    points: ComparePoints | None = Field(
        default=None, description="With `points=N`: up to N points of each part (a part has "
        "at most 3000), aligned, with their deviations.")
