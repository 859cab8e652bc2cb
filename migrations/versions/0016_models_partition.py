"""An index on each model's partition: ``ix_models_partition (tenant, descriptor_version,
status)``.

A metadata filter selects its models in SQL first (``app.search.similarity.matching_ids``):
the ids the filter's entries name, kept where the model is ready in the query's partition.
On SQLite that check read each model's row, and ``descriptor_version`` and ``status`` lie
past the descriptor's blob, on overflow pages: 43 ms for a filter that ten thousand models
pass (2 x 10^4 models), 14 ms for one that 2,000 pass. With the index the check reads the
index alone (rowid is its last column): 10 ms and 1.9 ms (``bench/scan_search.py
--filters``).

Revision ID: 0016
Revises: 0015
Create Date: 2026-12-05
"""

from __future__ import annotations

from collections.abc import Sequence

from alembic import op

revision: str = "0016"
down_revision: str | None = "0015"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_index("ix_models_partition", "models", ["tenant", "descriptor_version", "status"])


def downgrade() -> None:
    op.drop_index("ix_models_partition", table_name="models")
