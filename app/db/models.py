"""The tables, as SQLAlchemy 2 declarative models.

    models        one uploaded part: its file facts, status and, once described, its descriptor
    uploads       the original bytes of each model, apart so that listing models stays cheap
    jobs          the work queue: one describe job per model, claimed under a lease
    api_keys      hashed API keys, one tenant each
    model_revisions  each file a model has had (by external id upserts); a pending one
                  keeps its bytes until its job replaces the model's upload
    webhooks, webhook_deliveries, webhook_attempts  endpoints, the event outbox, the log
    idempotency_keys  the first answer to a POST /v1/models with an Idempotency-Key
    index_events  the change feed the search index of every API process follows
    feed_state    one row holding the last revision handed out to the change feed
    duplicate_reports, duplicate_groups  stored duplicate reports (app.search.duplicate_reports)
    assembly_parts  each placement of a part model in an assembly model (written by
                  app.ingest.assemblies, read by app.search.assemblies)

``index_id`` is the models' integer primary key because FAISS keys its vectors by int64;
the public identifier is the UUID ``id``.
"""

from __future__ import annotations

import uuid
from datetime import UTC, datetime
from typing import Any

from sqlalchemy import (
    JSON,
    BigInteger,
    Boolean,
    DateTime,
    Dialect,
    Float,
    ForeignKey,
    Index,
    Integer,
    LargeBinary,
    String,
    TypeDecorator,
    UniqueConstraint,
    Uuid,
    false,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, deferred, mapped_column

from core.descriptor import VERSION_LENGTH

__all__ = [
    "ApiKey",
    "AssemblyPart",
    "Base",
    "DuplicateGroup",
    "DuplicateReport",
    "FeedState",
    "IndexEvent",
    "Job",
    "Model",
    "IdempotencyKey",
    "ModelRevision",
    "Upload",
    "Webhook",
    "WebhookAttempt",
    "WebhookDelivery",
    "utcnow",
]

# SQLite has no BIGINT autoincrement: only "INTEGER PRIMARY KEY" is an alias of the rowid.
BigId = BigInteger().with_variant(Integer(), "sqlite")


def utcnow() -> datetime:
    return datetime.now(UTC)


class UTCDateTime(TypeDecorator[datetime]):
    """A timestamp that is always timezone-aware UTC in Python.

    SQLite stores naive text; PostgreSQL a ``timestamptz``. Both come back as aware UTC.
    """

    impl = DateTime(timezone=True)
    cache_ok = True

    def process_bind_param(self, value: datetime | None, dialect: Dialect) -> datetime | None:
        if value is None:
            return None
        if value.tzinfo is None:
            value = value.replace(tzinfo=UTC)
        value = value.astimezone(UTC)
        return value.replace(tzinfo=None) if dialect.name == "sqlite" else value

    def process_result_value(self, value: datetime | None, dialect: Dialect) -> datetime | None:
        if value is None:
            return None
        return value.replace(tzinfo=UTC) if value.tzinfo is None else value.astimezone(UTC)


class Base(DeclarativeBase):
    type_annotation_map = {datetime: UTCDateTime, dict[str, Any]: JSON}


class Model(Base):
    __tablename__ = "models"
    __table_args__ = (
        # NULL external ids never collide, on SQLite and PostgreSQL alike.
        UniqueConstraint("tenant", "external_id", name="uq_models_tenant_external_id"),
        Index("ix_models_tenant_created", "tenant", "created_at", "id"),
        Index("ix_models_status", "status"),
        # A model's partition: a metadata filter's ids are checked against it from the
        # index alone (revision 0016), not from rows whose blobs come first.
        Index("ix_models_partition", "tenant", "descriptor_version", "status"),
        Index("ix_models_size", "units", "size_length", "size_width", "size_height",
              "size_area", "size_volume", "tenant", "descriptor_version", "status"),
    )

    index_id: Mapped[int] = mapped_column(BigId, primary_key=True, autoincrement=True)
    id: Mapped[uuid.UUID] = mapped_column(Uuid, unique=True, default=uuid.uuid4)
    tenant: Mapped[str] = mapped_column(String(200))
    external_id: Mapped[str | None] = mapped_column(String(500))
    name: Mapped[str | None] = mapped_column(String(500))
    # "metadata" is reserved on declarative classes, hence the attribute name.
    meta: Mapped[dict[str, Any]] = mapped_column("metadata", JSON, default=dict)
    status: Mapped[str] = mapped_column(String(20), default="queued")
    error: Mapped[dict[str, Any] | None] = mapped_column(JSON)

    file_name: Mapped[str] = mapped_column(String(500))
    file_size: Mapped[int] = mapped_column(BigInteger)
    file_sha256: Mapped[str] = mapped_column(String(64))
    file_format: Mapped[str] = mapped_column(String(20))

    n_points: Mapped[int | None] = mapped_column(Integer)
    # core.cutoff.CutoffRecord.to_json() (rows written before it held the adaptive
    # parameters under "params"; CutoffRecord.from_json reads both)
    cutoff: Mapped[dict[str, Any] | None] = mapped_column(JSON)
    eigenvalues: Mapped[list[float] | None] = deferred(mapped_column(JSON))
    # float32 bytes of a unit vector; deferred so that lists do not carry vectors.
    descriptor: Mapped[bytes | None] = deferred(mapped_column(LargeBinary))
    descriptor_version: Mapped[str | None] = mapped_column(String(VERSION_LENGTH))
    # Scan mode (app.search.index, app.search.similarity): the descriptors of the model's
    # virtual partial views, (v, d) float32 bytes with v <= 16 (empty: none), and the model
    # described as a scan, d float32 bytes; deferred like descriptor.
    view_descriptors: Mapped[bytes | None] = deferred(mapped_column(LargeBinary))
    scan_descriptor: Mapped[bytes | None] = deferred(mapped_column(LargeBinary))
    timings: Mapped[dict[str, Any] | None] = mapped_column(JSON)
    # core.size.ShapeSize in the file's units (migration 0009): sorted extents, area, and
    # the volume of a watertight mesh; ``units`` as declared (mm, cm, m, in) or NULL.
    size_length: Mapped[float | None] = mapped_column(Float)
    size_width: Mapped[float | None] = mapped_column(Float)
    size_height: Mapped[float | None] = mapped_column(Float)
    size_area: Mapped[float | None] = mapped_column(Float)
    size_volume: Mapped[float | None] = mapped_column(Float)
    units: Mapped[str | None] = mapped_column(String(4))
    # app.ingest.previews blob for the viewer (points, HKS, eigenvalues); deferred like descriptor.
    preview: Mapped[bytes | None] = deferred(mapped_column(LargeBinary))
    # The description's points in the file's units and coordinates, (n, 3) float32
    # little-endian (migration 0017): what GET /v1/models/{id}/compare/{other} measures.
    sample: Mapped[bytes | None] = deferred(mapped_column(LargeBinary))

    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    updated_at: Mapped[datetime] = mapped_column(default=utcnow, onupdate=utcnow)


class Upload(Base):
    __tablename__ = "uploads"

    model_id: Mapped[uuid.UUID] = mapped_column(
        Uuid, ForeignKey("models.id", ondelete="CASCADE"), primary_key=True
    )
    content: Mapped[bytes] = mapped_column(LargeBinary)


class Job(Base):
    __tablename__ = "jobs"
    __table_args__ = (
        Index("ix_jobs_claim", "status", "turn", "run_after"),
        Index("ix_jobs_tenant_turn", "tenant", "background", "status", "turn"),
        Index("ix_jobs_tenant_created", "tenant", "created_at", "id"),
        # Settled jobs by age (app.db.retention walks them when pruning the history).
        Index("ix_jobs_settled", "status", "updated_at", "id"),
    )

    id: Mapped[uuid.UUID] = mapped_column(Uuid, primary_key=True, default=uuid.uuid4)
    # Several per model since revision 0002: the first describe, re-describes, new revisions.
    # None for a job about no one model (a duplicates report, revision 0010).
    model_id: Mapped[uuid.UUID | None] = mapped_column(
        Uuid, ForeignKey("models.id", ondelete="CASCADE"), index=True
    )
    tenant: Mapped[str] = mapped_column(String(200))
    # describe (first description) | redescribe (stored upload or a new revision) |
    # duplicates (a duplicates report of the tenant, with its parameters in ``params``)
    kind: Mapped[str] = mapped_column(String(20), default="describe")
    params: Mapped[dict[str, Any] | None] = mapped_column(JSON)
    # The revision whose file this job describes; None: the model's current upload.
    revision_id: Mapped[uuid.UUID | None] = mapped_column(Uuid)
    # queued | running | done | failed
    status: Mapped[str] = mapped_column(String(20), default="queued")
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    run_after: Mapped[datetime] = mapped_column(default=utcnow)
    # The job's turn among the tenants' queued jobs (app.jobs.turns): due jobs are claimed
    # in turn order, so one tenant's backlog does not hold up another tenant's uploads.
    turn: Mapped[int] = mapped_column(BigInteger, default=0, server_default="0")
    # Part of a bulk load: an upload sent with background=true (``shapesearch import``) or
    # the operator's re-describe of a whole catalogue. A tenant's background jobs take turns
    # apart from its other jobs, so its bulk loads do not hold up its uploads (revision 0012).
    background: Mapped[bool] = mapped_column(Boolean, default=False, server_default=false())
    leased_until: Mapped[datetime | None] = mapped_column()
    worker_id: Mapped[str | None] = mapped_column(String(200))
    last_error: Mapped[dict[str, Any] | None] = mapped_column(JSON)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    updated_at: Mapped[datetime] = mapped_column(default=utcnow, onupdate=utcnow)


class ApiKey(Base):
    __tablename__ = "api_keys"

    id: Mapped[uuid.UUID] = mapped_column(Uuid, primary_key=True, default=uuid.uuid4)
    tenant: Mapped[str] = mapped_column(String(200))
    # Public part of the key, to find the row; the secret is only stored hashed.
    prefix: Mapped[str] = mapped_column(String(32), index=True)
    key_sha256: Mapped[str] = mapped_column(String(64))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class IndexEvent(Base):
    """A model entered (``ready``) or left (``deleted``) the searchable set."""

    __tablename__ = "index_events"

    # Taken from feed_state under its row lock, so revisions commit in order.
    __table_args__ = (Index("ix_index_events_tenant", "tenant", "revision"),)

    revision: Mapped[int] = mapped_column(BigInteger, primary_key=True, autoincrement=False)
    index_id: Mapped[int] = mapped_column(BigInteger)
    kind: Mapped[str] = mapped_column(String(20))
    # The model's tenant (revision 0010; NULL in older events): a stored duplicates report
    # is stale once an event of its tenant is newer than the revision it was computed at.
    tenant: Mapped[str | None] = mapped_column(String(200))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class FeedState(Base):
    __tablename__ = "feed_state"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    revision: Mapped[int] = mapped_column(BigInteger, default=0)
    # The newest revision whose event was pruned (revision 0015, ``app.db.retention``): a
    # reader behind it may have missed an event and must rebuild instead of following.
    pruned_through: Mapped[int] = mapped_column(BigInteger, default=0, server_default="0")


class ModelRevision(Base):
    """One file of a model. ``current`` is the file the descriptor was computed from;
    a ``pending`` revision waits for its job, holding its bytes until then."""

    __tablename__ = "model_revisions"
    __table_args__ = (UniqueConstraint("model_id", "number", name="uq_model_revisions_number"),)

    id: Mapped[uuid.UUID] = mapped_column(Uuid, primary_key=True, default=uuid.uuid4)
    model_id: Mapped[uuid.UUID] = mapped_column(
        Uuid, ForeignKey("models.id", ondelete="CASCADE"), index=True
    )
    number: Mapped[int] = mapped_column(Integer)
    # pending | current | superseded | failed
    status: Mapped[str] = mapped_column(String(20))
    file_name: Mapped[str] = mapped_column(String(500))
    file_size: Mapped[int] = mapped_column(BigInteger)
    file_sha256: Mapped[str] = mapped_column(String(64))
    file_format: Mapped[str] = mapped_column(String(20))
    content: Mapped[bytes | None] = deferred(mapped_column(LargeBinary))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class Webhook(Base):
    __tablename__ = "webhooks"

    id: Mapped[uuid.UUID] = mapped_column(Uuid, primary_key=True, default=uuid.uuid4)
    tenant: Mapped[str] = mapped_column(String(200), index=True)
    url: Mapped[str] = mapped_column(String(2000))
    events: Mapped[list[str]] = mapped_column(JSON)
    secret: Mapped[str] = mapped_column(String(200))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class WebhookDelivery(Base):
    """One event for one endpoint: the outbox row, written with the change it reports,
    and claimed by a deliverer under a lease like a job."""

    __tablename__ = "webhook_deliveries"
    __table_args__ = (
        Index("ix_webhook_deliveries_claim", "status", "turn", "run_after"),
        Index("ix_webhook_deliveries_endpoint_turn", "webhook_id", "status", "turn"),
        # An endpoint's deliveries newest first (GET /v1/webhooks/{id}/deliveries).
        Index("ix_webhook_deliveries_endpoint_created", "webhook_id", "created_at"),
        # Settled deliveries by age (app.db.retention).
        Index("ix_webhook_deliveries_settled", "status", "updated_at", "id"),
    )

    # Also the Standard Webhooks message id (``webhook-id``): retries reuse it.
    id: Mapped[uuid.UUID] = mapped_column(Uuid, primary_key=True, default=uuid.uuid4)
    webhook_id: Mapped[uuid.UUID] = mapped_column(
        Uuid, ForeignKey("webhooks.id", ondelete="CASCADE"), index=True
    )
    event_type: Mapped[str] = mapped_column(String(50))
    payload: Mapped[dict[str, Any]] = mapped_column(JSON)
    # pending | delivered | failed
    status: Mapped[str] = mapped_column(String(20), default="pending")
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    run_after: Mapped[datetime] = mapped_column(default=utcnow)
    # The delivery's turn among the endpoints' pending deliveries (app.jobs.turns).
    turn: Mapped[int] = mapped_column(BigInteger, default=0, server_default="0")
    leased_until: Mapped[datetime | None] = mapped_column()
    worker_id: Mapped[str | None] = mapped_column(String(200))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    updated_at: Mapped[datetime] = mapped_column(default=utcnow, onupdate=utcnow)


class WebhookAttempt(Base):
    __tablename__ = "webhook_attempts"

    id: Mapped[int] = mapped_column(BigId, primary_key=True, autoincrement=True)
    delivery_id: Mapped[uuid.UUID] = mapped_column(
        Uuid, ForeignKey("webhook_deliveries.id", ondelete="CASCADE"), index=True
    )
    attempt: Mapped[int] = mapped_column(Integer)
    status_code: Mapped[int | None] = mapped_column(Integer)
    error: Mapped[str | None] = mapped_column(String(2000))
    duration_ms: Mapped[float] = mapped_column(Float)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class IdempotencyKey(Base):
    __tablename__ = "idempotency_keys"

    tenant: Mapped[str] = mapped_column(String(200), primary_key=True)
    key: Mapped[str] = mapped_column(String(300), primary_key=True)
    request_sha256: Mapped[str] = mapped_column(String(64))
    status_code: Mapped[int] = mapped_column(Integer)
    response: Mapped[dict[str, Any]] = mapped_column(JSON)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class DuplicateReport(Base):
    """One computed duplicates report of a tenant (``app.search.duplicate_reports``)."""

    __tablename__ = "duplicate_reports"
    __table_args__ = (
        Index("ix_duplicate_reports_lookup", "tenant", "descriptor_version", "computed_at"),
    )

    id: Mapped[uuid.UUID] = mapped_column(Uuid, primary_key=True, default=uuid.uuid4)
    tenant: Mapped[str] = mapped_column(String(200))
    # The job that computed it; None when ``shapesearch duplicates`` did.
    job_id: Mapped[uuid.UUID | None] = mapped_column(Uuid)
    # The parameters (app.search.duplicates.DuplicatesQuery).
    descriptor_version: Mapped[str] = mapped_column(String(VERSION_LENGTH))
    min_score: Mapped[float] = mapped_column(Float)
    size_tolerance: Mapped[float | None] = mapped_column(Float)
    neighbours: Mapped[int] = mapped_column(Integer)
    # The change-feed revision (index_events) whose searchable set the report describes.
    revision: Mapped[int] = mapped_column(BigInteger)
    models: Mapped[int] = mapped_column(Integer)  # ready models compared
    group_count: Mapped[int] = mapped_column(Integer)
    # Every pair compared (a flat index partition), or only pairs within nearby lists (IVF).
    exact: Mapped[bool] = mapped_column(Boolean)
    seconds: Mapped[float] = mapped_column(Float)  # the computation, loading included
    computed_at: Mapped[datetime] = mapped_column(default=utcnow)


class DuplicateGroup(Base):
    """One group of a stored report; ``number`` 1, 2, ... is its place, largest first."""

    __tablename__ = "duplicate_groups"

    report_id: Mapped[uuid.UUID] = mapped_column(
        Uuid, ForeignKey("duplicate_reports.id", ondelete="CASCADE"), primary_key=True
    )
    number: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=False)
    # The members' public ids (strings), oldest model first, and the edges that joined
    # them: [i, j, score] with i < j indexes of ``members``, best first.
    members: Mapped[list[str]] = mapped_column(JSON)
    pairs: Mapped[list[list[float]]] = mapped_column(JSON)


class AssemblyPart(Base):
    """One placement of a part in an assembly (migration 0018): both are models of the same
    tenant; a part placed n times has n rows, ``instance`` 0 to n - 1. Deleting either model
    deletes its rows; a new revision of the assembly replaces all of its rows at once."""

    __tablename__ = "assembly_parts"
    __table_args__ = (
        # Where-used: the assemblies that hold a part.
        Index("ix_assembly_parts_part", "tenant", "part_id"),
    )

    assembly_id: Mapped[uuid.UUID] = mapped_column(
        Uuid, ForeignKey("models.id", ondelete="CASCADE"), primary_key=True
    )
    part_id: Mapped[uuid.UUID] = mapped_column(
        Uuid, ForeignKey("models.id", ondelete="CASCADE"), primary_key=True
    )
    instance: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=False)
    tenant: Mapped[str] = mapped_column(String(200))
    # The 4x4 transform from the part's frame to the assembly's, 16 floats row-major.
    placement: Mapped[list[float]] = mapped_column(JSON)
