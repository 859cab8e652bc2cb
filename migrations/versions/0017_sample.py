"""models.sample: the points a model was described from, in its file's units.

Issue 75: ``GET /v1/models/{id}/compare/{other_id}`` places one part on another and
measures their deviations in the parts' units. The preview (revision 0004) holds 2000 of the
points centred and scaled to unit surface area, in float16; scaled back by the square root
of ``size_area`` (a mesh's triangle area, not the Laplacian's area the points were scaled by)
its figures are off by the difference. ``sample`` holds the description's points as loaded
(``core.pipeline.Description.sample``: at most ``max_points``, 3000 by default), float32
little-endian ``(n, 3)``, in the file's coordinates. Written by every describe; models
described before this revision compare on their previews until they are re-described.

Revision ID: 0017
Revises: 0016
Create Date: 2026-12-07
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0017"
down_revision: str | None = "0016"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    # Plain ADD COLUMN, not a batch copy: on SQLite a batch would rebuild the table and drop
    # the metadata triggers of 0007 with it.
    op.add_column("models", sa.Column("sample", sa.LargeBinary(), nullable=True))


def downgrade() -> None:
    op.drop_column("models", "sample")  # SQLite >= 3.35 drops a column in place
