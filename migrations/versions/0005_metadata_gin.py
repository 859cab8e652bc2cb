"""Metadata filters pushed down to SQL: an index that serves them on each backend.

``app.search.similarity`` selects the models matching a selective filter with

* PostgreSQL: ``CAST(metadata AS jsonb) @> '{"key": value}'``, served by a GIN expression
  index (``jsonb_path_ops``: smaller and faster for ``@>``);
* SQLite: ``json_extract(metadata, '$."key"') = value``, which no index can serve for any
  key; a covering index on (tenant, descriptor_version, status, metadata) lets the scan
  read index entries instead of table rows that each carry a 6 kB descriptor.

Revision ID: 0005
Revises: 0004
Create Date: 2026-11-22
"""

from __future__ import annotations

from collections.abc import Sequence

from alembic import op

revision: str = "0005"
down_revision: str | None = "0004"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    if op.get_bind().dialect.name == "postgresql":
        op.execute(
            "CREATE INDEX ix_models_metadata_gin ON models "
            "USING gin ((CAST(metadata AS jsonb)) jsonb_path_ops)"
        )
    else:
        op.create_index(
            "ix_models_partition_metadata",
            "models",
            ["tenant", "descriptor_version", "status", "metadata"],
        )


def downgrade() -> None:
    if op.get_bind().dialect.name == "postgresql":
        op.execute("DROP INDEX ix_models_metadata_gin")
    else:
        op.drop_index("ix_models_partition_metadata", "models")
