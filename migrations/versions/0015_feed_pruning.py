"""The change feed is pruned too: ``feed_state.pruned_through``.

``index_events`` gained a row with every model that became ready or was deleted, forever:
after ``jobs`` and ``webhook_deliveries`` (revision 0014) it was the last table that grew
with the service's age rather than its catalogue. ``app.db.retention`` now deletes events
older than ``SHAPESEARCH_HISTORY_DAYS`` (each tenant's newest stays: it dates the tenant's
duplicates reports) and records the newest revision it deleted here, so that an index that
fell behind it rebuilds instead of missing the events that are gone.

Revision ID: 0015
Revises: 0014
Create Date: 2026-12-05
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0015"
down_revision: str | None = "0014"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    # Plain ADD COLUMN, not a batch copy: nothing was pruned before this revision.
    op.add_column(
        "feed_state",
        sa.Column("pruned_through", sa.BigInteger(), nullable=False, server_default="0"),
    )


def downgrade() -> None:
    op.drop_column("feed_state", "pruned_through")
