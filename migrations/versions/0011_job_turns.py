"""Turns among tenants in the job queue.

``jobs.turn``: a job's place in the round among the tenants' queued jobs
(``app.jobs.turns``). Jobs were claimed oldest first, so one tenant's import of thousands of
files held every other tenant's uploads until it had drained; they are now claimed in turn
order (then oldest first), and a tenant's new job takes the turn after its own last queued
job, or the queue's head. Jobs queued before this revision keep turn 0 and so run first, in
the order they ran before.

Revision ID: 0011
Revises: 0010
Create Date: 2026-12-02
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0011"
down_revision: str | None = "0010"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    # Plain ADD COLUMN, not a batch copy (a batch would rebuild the table on SQLite).
    op.add_column(
        "jobs", sa.Column("turn", sa.BigInteger(), nullable=False, server_default="0")
    )
    # The claim walks due jobs in turn order; a new job reads the queue's head (the least
    # queued turn) and its tenant's last queued turn: one index seek each.
    op.drop_index("ix_jobs_claim", table_name="jobs")
    op.create_index("ix_jobs_claim", "jobs", ["status", "turn", "run_after"])
    op.create_index("ix_jobs_tenant_turn", "jobs", ["tenant", "status", "turn"])


def downgrade() -> None:
    op.drop_index("ix_jobs_tenant_turn", table_name="jobs")
    op.drop_index("ix_jobs_claim", table_name="jobs")
    op.create_index("ix_jobs_claim", "jobs", ["status", "run_after"])
    op.drop_column("jobs", "turn")
