"""PLM integration: several jobs per model, revisions, webhooks (outbox), idempotency keys.

Revision ID: 0002
Revises: 0001
Create Date: 2026-11-22
"""

from __future__ import annotations

import uuid
from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

from app.db.models import UTCDateTime

revision: str = "0002"
down_revision: str | None = "0001"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

BigId = sa.BigInteger().with_variant(sa.Integer(), "sqlite")
# Names the unnamed unique constraint of jobs.model_id that SQLite reflects without a name.
_NAMING = {"uq": "uq_%(table_name)s_%(column_0_name)s"}


def _jobs_allow_several_per_model() -> None:
    if op.get_bind().dialect.name == "postgresql":
        op.drop_constraint("jobs_model_id_key", "jobs", type_="unique")
        op.add_column("jobs", sa.Column("kind", sa.String(20), nullable=False,
                                        server_default="describe"))
        op.add_column("jobs", sa.Column("revision_id", sa.Uuid()))
    else:
        with op.batch_alter_table("jobs", naming_convention=_NAMING, recreate="always") as batch:
            batch.drop_constraint("uq_jobs_model_id", type_="unique")
            batch.add_column(sa.Column("kind", sa.String(20), nullable=False,
                                       server_default="describe"))
            batch.add_column(sa.Column("revision_id", sa.Uuid()))
    op.create_index("ix_jobs_model_id", "jobs", ["model_id"])
    op.create_index("ix_jobs_tenant_created", "jobs", ["tenant", "created_at", "id"])


def _revisions() -> None:
    revisions = op.create_table(
        "model_revisions",
        sa.Column("id", sa.Uuid(), primary_key=True),
        sa.Column(
            "model_id", sa.Uuid(), sa.ForeignKey("models.id", ondelete="CASCADE"), nullable=False
        ),
        sa.Column("number", sa.Integer(), nullable=False),
        sa.Column("status", sa.String(20), nullable=False),
        sa.Column("file_name", sa.String(500), nullable=False),
        sa.Column("file_size", sa.BigInteger(), nullable=False),
        sa.Column("file_sha256", sa.String(64), nullable=False),
        sa.Column("file_format", sa.String(20), nullable=False),
        sa.Column("content", sa.LargeBinary()),
        sa.Column("created_at", UTCDateTime(), nullable=False),
        sa.UniqueConstraint("model_id", "number", name="uq_model_revisions_number"),
    )
    op.create_index("ix_model_revisions_model_id", "model_revisions", ["model_id"])
    # Models uploaded before this revision get their first file as revision 1.
    models = sa.table(
        "models",
        sa.column("id", sa.Uuid()),
        sa.column("file_name", sa.String()),
        sa.column("file_size", sa.BigInteger()),
        sa.column("file_sha256", sa.String()),
        sa.column("file_format", sa.String()),
        sa.column("created_at", UTCDateTime()),
    )
    rows = op.get_bind().execute(sa.select(models)).all()
    if rows:
        op.bulk_insert(
            revisions,
            [
                {
                    "id": uuid.uuid4(), "model_id": row.id, "number": 1, "status": "current",
                    "file_name": row.file_name, "file_size": row.file_size,
                    "file_sha256": row.file_sha256, "file_format": row.file_format,
                    "content": None, "created_at": row.created_at,
                }
                for row in rows
            ],
        )


def _webhooks() -> None:
    op.create_table(
        "webhooks",
        sa.Column("id", sa.Uuid(), primary_key=True),
        sa.Column("tenant", sa.String(200), nullable=False),
        sa.Column("url", sa.String(2000), nullable=False),
        sa.Column("events", sa.JSON(), nullable=False),
        sa.Column("secret", sa.String(200), nullable=False),
        sa.Column("created_at", UTCDateTime(), nullable=False),
    )
    op.create_index("ix_webhooks_tenant", "webhooks", ["tenant"])
    op.create_table(
        "webhook_deliveries",
        sa.Column("id", sa.Uuid(), primary_key=True),
        sa.Column(
            "webhook_id",
            sa.Uuid(),
            sa.ForeignKey("webhooks.id", ondelete="CASCADE"),
            nullable=False,
        ),
        sa.Column("event_type", sa.String(50), nullable=False),
        sa.Column("payload", sa.JSON(), nullable=False),
        sa.Column("status", sa.String(20), nullable=False),
        sa.Column("attempts", sa.Integer(), nullable=False),
        sa.Column("run_after", UTCDateTime(), nullable=False),
        sa.Column("leased_until", UTCDateTime()),
        sa.Column("worker_id", sa.String(200)),
        sa.Column("created_at", UTCDateTime(), nullable=False),
        sa.Column("updated_at", UTCDateTime(), nullable=False),
    )
    op.create_index("ix_webhook_deliveries_claim", "webhook_deliveries", ["status", "run_after"])
    op.create_index("ix_webhook_deliveries_webhook_id", "webhook_deliveries", ["webhook_id"])
    op.create_table(
        "webhook_attempts",
        sa.Column("id", BigId, primary_key=True, autoincrement=True),
        sa.Column(
            "delivery_id",
            sa.Uuid(),
            sa.ForeignKey("webhook_deliveries.id", ondelete="CASCADE"),
            nullable=False,
        ),
        sa.Column("attempt", sa.Integer(), nullable=False),
        sa.Column("status_code", sa.Integer()),
        sa.Column("error", sa.String(2000)),
        sa.Column("duration_ms", sa.Float(), nullable=False),
        sa.Column("created_at", UTCDateTime(), nullable=False),
    )
    op.create_index("ix_webhook_attempts_delivery_id", "webhook_attempts", ["delivery_id"])


def upgrade() -> None:
    _jobs_allow_several_per_model()
    _revisions()
    _webhooks()
    op.create_table(
        "idempotency_keys",
        sa.Column("tenant", sa.String(200), primary_key=True),
        sa.Column("key", sa.String(300), primary_key=True),
        sa.Column("request_sha256", sa.String(64), nullable=False),
        sa.Column("status_code", sa.Integer(), nullable=False),
        sa.Column("response", sa.JSON(), nullable=False),
        sa.Column("created_at", UTCDateTime(), nullable=False),
    )


def downgrade() -> None:
    for table in (
        "idempotency_keys", "webhook_attempts", "webhook_deliveries", "webhooks",
        "model_revisions",
    ):
        op.drop_table(table)
    op.drop_index("ix_jobs_tenant_created", "jobs")
    op.drop_index("ix_jobs_model_id", "jobs")
    with op.batch_alter_table("jobs") as batch:
        batch.drop_column("revision_id")
        batch.drop_column("kind")
        batch.create_unique_constraint("uq_jobs_model_id", ["model_id"])
