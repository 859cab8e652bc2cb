"""SQLite: metadata filters served by an index, through a table of (key, value) rows.

PostgreSQL serves a selective metadata filter from the GIN index of 0005. SQLite has no
index for ``json_extract(metadata, '$."key"')`` over any key, so 0005's covering index only
made the scan of every row of a tenant cheaper: ~19 ms at 10^5 models, the whole of a
filtered search's time. Here each top-level metadata entry of a model becomes a row of
``metadata_values (index_id, tenant, key, value)``, indexed on (tenant, key, value), so a
filter reads only the matching entries. Triggers on ``models`` keep the rows in step with
every insert, change and delete, whoever writes (the API, workers, an import), and the
rows hold ``json_each``'s values, which compare exactly as ``json_extract``'s did (text,
integer, real; JSON text for arrays and objects). The covering index of 0005 has no use
left and goes.

Revision ID: 0007
Revises: 0006
Create Date: 2026-11-23
"""

from __future__ import annotations

from collections.abc import Sequence

from alembic import op

revision: str = "0007"
down_revision: str | None = "0006"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def _entries(metadata: str) -> str:
    """``json_each`` over the column ``metadata``: its entries, none unless it holds a JSON
    object."""
    return (
        f"json_each(CASE WHEN json_valid({metadata}) AND json_type({metadata}) = 'object' "
        f"THEN {metadata} ELSE '{{}}' END)"
    )


def upgrade() -> None:
    if op.get_bind().dialect.name != "sqlite":
        return
    # ``value`` has no declared type: SQLite keeps each value's own storage class.
    op.execute(
        "CREATE TABLE metadata_values ("
        "index_id INTEGER NOT NULL, tenant VARCHAR NOT NULL, key TEXT NOT NULL, value)"
    )
    op.execute("CREATE INDEX ix_metadata_values_lookup ON metadata_values (tenant, key, value)")
    op.execute("CREATE INDEX ix_metadata_values_model ON metadata_values (index_id)")
    insert = (
        "INSERT INTO metadata_values (index_id, tenant, key, value) "
        f"SELECT NEW.index_id, NEW.tenant, key, value FROM {_entries('NEW.metadata')};"
    )
    forget = "DELETE FROM metadata_values WHERE index_id = OLD.index_id;"
    op.execute(f"CREATE TRIGGER metadata_values_insert AFTER INSERT ON models BEGIN {insert} END")
    op.execute(
        "CREATE TRIGGER metadata_values_update AFTER UPDATE OF metadata, tenant ON models "
        f"BEGIN {forget} {insert} END"
    )
    op.execute(f"CREATE TRIGGER metadata_values_delete AFTER DELETE ON models BEGIN {forget} END")
    op.execute(
        "INSERT INTO metadata_values (index_id, tenant, key, value) "
        f"SELECT m.index_id, m.tenant, e.key, e.value FROM models AS m, {_entries('m.metadata')}"
        " AS e"
    )
    op.drop_index("ix_models_partition_metadata", "models")


def downgrade() -> None:
    if op.get_bind().dialect.name != "sqlite":
        return
    op.create_index(
        "ix_models_partition_metadata",
        "models",
        ["tenant", "descriptor_version", "status", "metadata"],
    )
    for trigger in ("insert", "update", "delete"):
        op.execute(f"DROP TRIGGER metadata_values_{trigger}")
    op.drop_table("metadata_values")
