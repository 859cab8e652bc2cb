"""An endpoint's deliveries, newest first, read from an index.

``GET /v1/webhooks/{id}/deliveries`` lists an endpoint's newest deliveries; with only
``webhook_id`` indexed, every call sorted the endpoint's whole history (50 of 200,000 took
745 ms on SQLite). ``ix_webhook_deliveries_endpoint_created`` (``webhook_id``,
``created_at``) gives them in order.

Revision ID: 0013
Revises: 0012
Create Date: 2026-12-05
"""

from __future__ import annotations

from collections.abc import Sequence

from alembic import op

revision: str = "0013"
down_revision: str | None = "0012"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_index(
        "ix_webhook_deliveries_endpoint_created",
        "webhook_deliveries",
        ["webhook_id", "created_at"],
    )


def downgrade() -> None:
    op.drop_index("ix_webhook_deliveries_endpoint_created", table_name="webhook_deliveries")
