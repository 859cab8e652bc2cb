"""models.view_descriptors and models.scan_descriptor: scan mode's extra entries.

``view_descriptors`` holds the descriptors of a model's virtual partial views (``v * d``
float32, v <= 16; indexed as extra entries of the model, ``app.search.index``) and
``scan_descriptor`` the model described as a scan (``d`` float32, the query of
``/similar?mode=scan``). Both are filled by the worker with the model's descriptor; models
described before this migration have neither until they are described again
(``shapesearch redescribe --all``); until then scan mode compares them whole.

Revision ID: 0006
Revises: 0005
Create Date: 2026-11-22
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0006"
down_revision: str | None = "0005"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.add_column("models", sa.Column("view_descriptors", sa.LargeBinary(), nullable=True))
    op.add_column("models", sa.Column("scan_descriptor", sa.LargeBinary(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("models") as batch:
        batch.drop_column("scan_descriptor")
        batch.drop_column("view_descriptors")
