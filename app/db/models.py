"""The tables, as SQLAlchemy 2 declarative models.

    models        one uploaded part: its file facts, status and, once described, its descriptor
    uploads       the original bytes of each model, apart so that listing models stays cheap
    jobs          the work queue: one describe job per model, claimed under a lease
    api_keys      hashed API keys, one tenant each
    index_events  the change feed the search index of every API process follows
    feed_state    one row holding the last revision handed out to the change feed

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
    DateTime,
    Dialect,
    ForeignKey,
    Index,
    Integer,
    LargeBinary,
    String,
    TypeDecorator,
    UniqueConstraint,
    Uuid,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, deferred, mapped_column

__all__ = [
    "ApiKey",
    "Base",
    "FeedState",
    "IndexEvent",
    "Job",
    "Model",
    "Upload",
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
    # {"mode", "n", "solver_calls", "params": {...}, "predicted": [...]}
    cutoff: Mapped[dict[str, Any] | None] = mapped_column(JSON)
    eigenvalues: Mapped[list[float] | None] = deferred(mapped_column(JSON))
    # float32 bytes of a unit vector; deferred so that lists do not carry vectors.
    descriptor: Mapped[bytes | None] = deferred(mapped_column(LargeBinary))
    descriptor_version: Mapped[str | None] = mapped_column(String(200))
    timings: Mapped[dict[str, Any] | None] = mapped_column(JSON)
    # app.previews blob for the viewer (points, HKS, eigenvalues); deferred like descriptor.
    preview: Mapped[bytes | None] = deferred(mapped_column(LargeBinary))

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
    __table_args__ = (Index("ix_jobs_claim", "status", "run_after"),)

    id: Mapped[uuid.UUID] = mapped_column(Uuid, primary_key=True, default=uuid.uuid4)
    model_id: Mapped[uuid.UUID] = mapped_column(
        Uuid, ForeignKey("models.id", ondelete="CASCADE"), unique=True
    )
    tenant: Mapped[str] = mapped_column(String(200))
    # queued | running | done | failed
    status: Mapped[str] = mapped_column(String(20), default="queued")
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    run_after: Mapped[datetime] = mapped_column(default=utcnow)
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
    revision: Mapped[int] = mapped_column(BigInteger, primary_key=True, autoincrement=False)
    index_id: Mapped[int] = mapped_column(BigInteger)
    kind: Mapped[str] = mapped_column(String(20))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class FeedState(Base):
    __tablename__ = "feed_state"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    revision: Mapped[int] = mapped_column(BigInteger, default=0)
