"""assembly_parts: the parts of an assembly uploaded with assembly=split, with placements.

Issue 76: an assembly's geometry nodes (GLB, OBJ) or solids (STEP) become part models; each
placement of a part in its assembly is one row (``instance`` 0 to n - 1 per part), with its
4x4 transform as 16 floats. Rows go with either model (ON DELETE CASCADE); where-used reads
them by ``(tenant, part_id)``.

Revision ID: 0018
Revises: 0017
Create Date: 2026-12-07
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0018"
down_revision: str | None = "0017"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        "assembly_parts",
        sa.Column(
            "assembly_id", sa.Uuid(), sa.ForeignKey("models.id", ondelete="CASCADE"),
            primary_key=True,
        ),
        sa.Column(
            "part_id", sa.Uuid(), sa.ForeignKey("models.id", ondelete="CASCADE"),
            primary_key=True,
        ),
        sa.Column("instance", sa.Integer(), primary_key=True, autoincrement=False),
        sa.Column("tenant", sa.String(200), nullable=False),
        sa.Column("placement", sa.JSON(), nullable=False),
    )
    op.create_index("ix_assembly_parts_part", "assembly_parts", ["tenant", "part_id"])


def downgrade() -> None:
    op.drop_index("ix_assembly_parts_part", table_name="assembly_parts")
    op.drop_table("assembly_parts")
