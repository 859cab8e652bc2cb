"""Settled jobs and webhook deliveries by age, for pruning the history.

``app.db.retention`` deletes jobs and deliveries settled longer ago than
``SHAPESEARCH_HISTORY_DAYS``. Found through the claim indexes, every batch of a pass read
and sorted all settled rows again (a pass over 10^5 models' history took 208 s, and each
batch's read grew with the table). ``ix_jobs_settled`` and ``ix_webhook_deliveries_settled``
(``status``, ``updated_at``, ``id``) let a pass walk the old settled rows once, in order.

Revision ID: 0014
Revises: 0013
Create Date: 2026-12-05
"""

from __future__ import annotations

from collections.abc import Sequence

from alembic import op

revision: str = "0014"
down_revision: str | None = "0013"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_index("ix_jobs_settled", "jobs", ["status", "updated_at", "id"])
    op.create_index(
        "ix_webhook_deliveries_settled", "webhook_deliveries", ["status", "updated_at", "id"]
    )


def downgrade() -> None:
    op.drop_index("ix_webhook_deliveries_settled", table_name="webhook_deliveries")
    op.drop_index("ix_jobs_settled", table_name="jobs")
