"""Metadata filters pushed down to SQL: a GIN index on models.metadata (PostgreSQL only).

``app.similarity`` selects the models matching a selective filter with
``CAST(metadata AS jsonb) @> '{"key": value}'``; this expression index (``jsonb_path_ops``:
smaller and faster for ``@>``) serves it. SQLite evaluates ``json_extract`` per row.

Revision ID: 0005
Revises: 0001
Create Date: 2026-11-22
"""

from __future__ import annotations

from collections.abc import Sequence

from alembic import op

revision: str = "0005"
down_revision: str | None = "0001"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    if op.get_bind().dialect.name == "postgresql":
        op.execute(
            "CREATE INDEX ix_models_metadata_gin ON models "
            "USING gin ((CAST(metadata AS jsonb)) jsonb_path_ops)"
        )


def downgrade() -> None:
    if op.get_bind().dialect.name == "postgresql":
        op.execute("DROP INDEX ix_models_metadata_gin")
