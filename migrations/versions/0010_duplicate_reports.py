"""Stored duplicates reports, computed by a job.

Issue 22: ``POST /v1/duplicates`` queues a job that computes the report once and stores it;
``GET /v1/duplicates`` pages the stored report.

* ``jobs.model_id`` may be NULL (a duplicates job is about no one model) and ``jobs.params``
  holds a job's parameters;
* ``index_events.tenant``: whose model an event is about, so that "has this tenant's
  searchable set changed since revision R" (a report's ``stale``) is one index seek;
* ``duplicate_reports`` (one row per report: tenant, parameters, the feed revision it
  describes, computed_at) and ``duplicate_groups`` (one row per group, its members and
  edges as JSON; paged by ``number``).

Revision ID: 0010
Revises: 0009
Create Date: 2026-11-26
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

from app.db.models import UTCDateTime

revision: str = "0010"
down_revision: str | None = "0009"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def _jobs(nullable: bool) -> None:
    if op.get_bind().dialect.name == "postgresql":
        op.alter_column("jobs", "model_id", existing_type=sa.Uuid(), nullable=nullable)
        return
    # SQLite cannot change a column's NOT NULL in place: the batch copies the table.
    with op.batch_alter_table("jobs", recreate="always") as batch:
        batch.alter_column("model_id", existing_type=sa.Uuid(), nullable=nullable)


def upgrade() -> None:
    _jobs(nullable=True)
    op.add_column("jobs", sa.Column("params", sa.JSON()))
    op.add_column("index_events", sa.Column("tenant", sa.String(200)))
    op.create_index("ix_index_events_tenant", "index_events", ["tenant", "revision"])
    op.create_table(
        "duplicate_reports",
        sa.Column("id", sa.Uuid(), primary_key=True),
        sa.Column("tenant", sa.String(200), nullable=False),
        sa.Column("job_id", sa.Uuid()),
        sa.Column("descriptor_version", sa.String(255), nullable=False),
        sa.Column("min_score", sa.Float(), nullable=False),
        sa.Column("size_tolerance", sa.Float()),
        sa.Column("neighbours", sa.Integer(), nullable=False),
        sa.Column("revision", sa.BigInteger(), nullable=False),
        sa.Column("models", sa.Integer(), nullable=False),
        sa.Column("group_count", sa.Integer(), nullable=False),
        sa.Column("exact", sa.Boolean(), nullable=False),
        sa.Column("seconds", sa.Float(), nullable=False),
        sa.Column("computed_at", UTCDateTime(), nullable=False),
    )
    op.create_index(
        "ix_duplicate_reports_lookup", "duplicate_reports",
        ["tenant", "descriptor_version", "computed_at"],
    )
    op.create_table(
        "duplicate_groups",
        sa.Column(
            "report_id", sa.Uuid(),
            sa.ForeignKey("duplicate_reports.id", ondelete="CASCADE"), primary_key=True,
        ),
        sa.Column("number", sa.Integer(), primary_key=True, autoincrement=False),
        sa.Column("members", sa.JSON(), nullable=False),
        sa.Column("pairs", sa.JSON(), nullable=False),
    )


def downgrade() -> None:
    op.drop_table("duplicate_groups")
    op.drop_index("ix_duplicate_reports_lookup", table_name="duplicate_reports")
    op.drop_table("duplicate_reports")
    op.drop_index("ix_index_events_tenant", table_name="index_events")
    op.drop_column("index_events", "tenant")
    op.drop_column("jobs", "params")
    op.execute(sa.text("DELETE FROM jobs WHERE model_id IS NULL"))  # duplicates jobs
    _jobs(nullable=False)
