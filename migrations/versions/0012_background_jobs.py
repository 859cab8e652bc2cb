"""Background jobs take turns apart from a tenant's other jobs.

``jobs.background``: the job is part of a bulk load, an upload sent with background=true
(``shapesearch import`` sends it) or the operator's re-describe of a whole catalogue
(``shapesearch redescribe``). Turns (revision 0011) went round the tenants, so a tenant's
import or re-describe, one job per file, held every other upload of that same tenant until
it had drained: with one tenant, every upload. A job's turn now follows the last waiting job
of its tenant *and* of the same background flag (``app.jobs.turns``), so a tenant's uploads
and its bulk load take turns like two tenants. Jobs queued before this revision are not
background jobs (false).

Revision ID: 0012
Revises: 0011
Create Date: 2026-12-03
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0012"
down_revision: str | None = "0011"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    # Plain ADD COLUMN, not a batch copy (a batch would rebuild the table on SQLite).
    op.add_column(
        "jobs",
        sa.Column("background", sa.Boolean(), nullable=False, server_default=sa.false()),
    )
    # A new job reads the last waiting turn of its tenant's jobs of the same origin.
    op.drop_index("ix_jobs_tenant_turn", table_name="jobs")
    op.create_index("ix_jobs_tenant_turn", "jobs", ["tenant", "background", "status", "turn"])


def downgrade() -> None:
    op.drop_index("ix_jobs_tenant_turn", table_name="jobs")
    op.create_index("ix_jobs_tenant_turn", "jobs", ["tenant", "status", "turn"])
    op.drop_column("jobs", "background")
