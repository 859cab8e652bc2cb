"""What a job's end means for its model's files, and the latest job of each model.

A model has one *current* file (``uploads`` + the file columns of ``models``) and the
descriptor computed from it. A new file (``PUT /v1/models/by-external-id/...``) becomes a
*pending* revision holding its bytes; its job describes those bytes while the model keeps
serving the previous descriptor. When the job completes, ``promote`` makes the revision
current in the same transaction that stores the new descriptor: readers see either the old
file and descriptor or the new ones, never a mix.
"""

from __future__ import annotations

import uuid
from collections.abc import Iterable
from typing import Any

from sqlalchemy import func, select, update
from sqlalchemy.orm import Session

from app.db.models import Job, Model, ModelRevision, Upload
from app.jobs.turns import queue_job
from app.problems import problem

__all__ = [
    "add_revision",
    "create_model_rows",
    "enqueue_redescribe",
    "latest_jobs",
    "lock_models",
    "mark_revision_failed",
    "promote",
    "revision_content",
]


def lock_models(session: Session, *where: Any) -> list[uuid.UUID]:
    """Write-lock the models matching ``where`` (a no-op UPDATE) and return their ids.

    A write transaction must start with its write: on SQLite a transaction that reads
    first cannot take the write lock later (SQLITE_BUSY); on PostgreSQL it is the row lock.
    """
    return list(
        session.scalars(
            update(Model).where(*where).values(updated_at=Model.updated_at).returning(Model.id)
        )
    )


def add_revision(
    session: Session,
    model_id: uuid.UUID,
    *,
    file_name: str,
    file_size: int,
    file_sha256: str,
    file_format: str,
    content: bytes | None,
) -> ModelRevision:
    """Append the next revision; with ``content`` it is pending, without it current."""
    number = session.scalar(
        select(func.coalesce(func.max(ModelRevision.number), 0)).where(
            ModelRevision.model_id == model_id
        )
    )
    revision = ModelRevision(
        id=uuid.uuid4(),
        model_id=model_id,
        number=int(number or 0) + 1,
        status="current" if content is None else "pending",
        file_name=file_name,
        file_size=file_size,
        file_sha256=file_sha256,
        file_format=file_format,
        content=content,
    )
    session.add(revision)
    session.flush()
    return revision


def promote(session: Session, job_id: uuid.UUID, model_id: uuid.UUID) -> None:
    """Make the completed job's revision (if any) the model's current file."""
    revision_id = session.scalar(select(Job.revision_id).where(Job.id == job_id))
    if revision_id is None:
        return
    revision = session.get(ModelRevision, revision_id)
    if revision is None or revision.content is None:
        return
    session.execute(
        update(ModelRevision)
        .where(ModelRevision.model_id == model_id, ModelRevision.status == "current")
        .values(status="superseded")
    )
    session.execute(
        update(Upload).where(Upload.model_id == model_id).values(content=revision.content)
    )
    session.execute(
        update(Model)
        .where(Model.id == model_id)
        .values(
            file_name=revision.file_name,
            file_size=revision.file_size,
            file_sha256=revision.file_sha256,
            file_format=revision.file_format,
        )
    )
    revision.status = "current"
    revision.content = None  # the bytes now live in uploads


def mark_revision_failed(session: Session, job_id: uuid.UUID) -> None:
    """The failed job's pending revision is failed; the current file stays."""
    revision_id = session.scalar(select(Job.revision_id).where(Job.id == job_id))
    if revision_id is not None:
        session.execute(
            update(ModelRevision)
            .where(ModelRevision.id == revision_id, ModelRevision.status == "pending")
            .values(status="failed", content=None)
        )


def revision_content(session: Session, job_id: uuid.UUID) -> tuple[bytes, str] | None:
    """The bytes and file name a revision job describes, or None for a current-file job."""
    row = session.execute(
        select(ModelRevision.content, ModelRevision.file_name)
        .join(Job, Job.revision_id == ModelRevision.id)
        .where(Job.id == job_id, ModelRevision.content.is_not(None))
    ).one_or_none()
    return None if row is None else (bytes(row.content), row.file_name)


def latest_jobs(session: Session, model_ids: Iterable[uuid.UUID]) -> dict[uuid.UUID, Job]:
    """The newest job of each model, in one query."""
    ids = list(model_ids)
    if not ids:
        return {}
    jobs = session.scalars(
        select(Job).where(Job.model_id.in_(ids)).order_by(Job.created_at, Job.id)
    ).all()
    return {job.model_id: job for job in jobs if job.model_id is not None}  # later rows win


def create_model_rows(
    session: Session, model: Model, content: bytes, *, background: bool = False
) -> Job:
    """Add a new model with its upload, revision 1 and its describe job (one transaction:
    no accepted upload without a job); ``background``: the upload is part of a bulk load
    (``app.jobs.turns``)."""
    session.add(model)
    session.flush()
    session.add(Upload(model_id=model.id, content=content))
    add_revision(
        session,
        model.id,
        file_name=model.file_name,
        file_size=model.file_size,
        file_sha256=model.file_sha256,
        file_format=model.file_format,
        content=None,
    )
    return queue_job(
        session, tenant=model.tenant, background=background, model_id=model.id,
        kind="describe",
    )


def enqueue_redescribe(
    session: Session, model: Model, revision: ModelRevision | None = None, *,
    background: bool = False,
) -> Job:
    """A job that describes the model again: its current file, or ``revision``'s.

    Queued jobs of the model that have not started are failed as superseded, so that an
    older file cannot overwrite a newer one. ``background``: part of a bulk load or of a
    whole catalogue's re-describe (``app.jobs.turns``).
    """
    superseded = session.scalars(
        select(Job.revision_id).where(
            Job.model_id == model.id, Job.status == "queued", Job.revision_id.is_not(None)
        )
    ).all()
    if superseded:
        session.execute(
            update(ModelRevision)
            .where(ModelRevision.id.in_(superseded), ModelRevision.status == "pending")
            .values(status="superseded", content=None)
        )
    session.execute(
        update(Job)
        .where(Job.model_id == model.id, Job.status == "queued")
        .values(
            status="failed",
            last_error=problem(
                "superseded", "A newer job of this model replaced this one before it started."
            ),
        )
    )
    return queue_job(
        session, tenant=model.tenant, background=background, model_id=model.id,
        kind="redescribe", revision_id=None if revision is None else revision.id,
    )
