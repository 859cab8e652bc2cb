"""A longer ``models.descriptor_version``: 255 characters instead of 200.

The descriptor's local block adds itself to the readable part of the version
(``core.descriptor.DescriptorSpec.version``), which no longer fitted in 200 characters with
the extrinsic blocks' names. PostgreSQL enforces the length (the covering index of 0005 is
rebuilt with the column); SQLite does not, so there is nothing to do there.

Revision ID: 0008
Revises: 0007
Create Date: 2026-11-25
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0008"
down_revision: str | None = "0007"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def _resize(old: int, new: int) -> None:
    if op.get_bind().dialect.name != "postgresql":
        return
    op.alter_column(
        "models", "descriptor_version",
        existing_type=sa.String(old), type_=sa.String(new), existing_nullable=True,
    )


def upgrade() -> None:
    _resize(200, 255)


def downgrade() -> None:
    _resize(255, 200)
