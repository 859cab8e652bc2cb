"""Size columns: a model's extents, area and volume in its file's units, and those units.

Issue 21: the descriptor is scale-invariant, so size is stored beside it
(``core.size.ShapeSize``): ``size_length >= size_width >= size_height`` (the oriented
bounding box), ``size_area``, ``size_volume`` (watertight meshes only) and ``units`` (``mm``,
``cm``, ``m``, ``in`` as the client declared them, or NULL: compared as given). Models
described before this revision have no size until they are re-described
(``GET /v1/stats`` counts them).

Revision ID: 0009
Revises: 0008
Create Date: 2026-11-25
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0009"
down_revision: str | None = "0008"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

_SIZES = ("size_length", "size_width", "size_height", "size_area", "size_volume")


def upgrade() -> None:
    # Plain ADD COLUMN, not a batch copy: on SQLite a batch would rebuild the table and drop
    # the metadata triggers of 0007 with it.
    for name in _SIZES:
        op.add_column("models", sa.Column(name, sa.Float(), nullable=True))
    op.add_column("models", sa.Column("units", sa.String(4), nullable=True))
    # Size filters (app.search.sizing) bound each size per unit: this index serves them
    # (a range seek on units and length) and holds every column they read, so a selective
    # range never reads the rows' descriptors. Units and length lead, not the tenant: led by
    # the tenant, SQLite took it for metadata filters too and scanned the tenant's rows.
    op.create_index(
        "ix_models_size", "models",
        ["units", *_SIZES, "tenant", "descriptor_version", "status"],
    )


def downgrade() -> None:
    op.drop_index("ix_models_size", table_name="models")
    for name in (*_SIZES, "units"):
        op.drop_column("models", name)  # SQLite >= 3.35 drops a column in place
