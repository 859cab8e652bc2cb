"""Turns in the job queue (among tenants) and the webhook outbox (among endpoints).

``jobs.turn`` and ``webhook_deliveries.turn``: a row's place in the round among its queue's
owners (``app.jobs.turns``). Both queues were claimed oldest first, so one tenant's import of
thousands of files held every other tenant's uploads until it had drained, and an endpoint
that hung with a backlog held every other endpoint's events. Rows are now claimed in turn
order (then oldest first), and an owner's new row takes the turn after its own last waiting
row, or the queue's head. Rows queued before this revision keep turn 0 and so run first, in
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

# Each queue: its table, its claim index and the owner column of its second index.
_QUEUES = (
    ("jobs", "ix_jobs_claim", "tenant", "ix_jobs_tenant_turn"),
    ("webhook_deliveries", "ix_webhook_deliveries_claim", "webhook_id",
     "ix_webhook_deliveries_endpoint_turn"),
)


def upgrade() -> None:
    for table, claim_index, owner, owner_index in _QUEUES:
        # Plain ADD COLUMN, not a batch copy (a batch would rebuild the table on SQLite).
        op.add_column(
            table, sa.Column("turn", sa.BigInteger(), nullable=False, server_default="0")
        )
        # The claim walks due rows in turn order; a new row reads the queue's head (the
        # least waiting turn) and its owner's last waiting turn: one index seek each.
        op.drop_index(claim_index, table_name=table)
        op.create_index(claim_index, table, ["status", "turn", "run_after"])
        op.create_index(owner_index, table, [owner, "status", "turn"])


def downgrade() -> None:
    for table, claim_index, _owner, owner_index in _QUEUES:
        op.drop_index(owner_index, table_name=table)
        op.drop_index(claim_index, table_name=table)
        op.create_index(claim_index, table, ["status", "run_after"])
        op.drop_column(table, "turn")
