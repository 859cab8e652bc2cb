"""The migrations build the schema the models declare: a table, column or index added to
``app/db/models.py`` without its Alembic revision (or the other way round) fails here, on
SQLite and PostgreSQL alike."""

from __future__ import annotations

from typing import Any

from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext

from app.db.migrate import upgrade
from app.db.models import Base
from app.db.session import make_engine

# Differences that are meant: metadata filters use a GIN index on PostgreSQL (revision
# 0005) and on SQLite a lookup table kept by triggers (revision 0007), both outside the
# models; SQLite does not enforce a VARCHAR's length, so revision 0008 lengthens
# descriptor_version on PostgreSQL only.
_POSTGRESQL_ONLY = {("remove_index", "ix_models_metadata_gin")}
_SQLITE_ONLY = {
    ("remove_table", "metadata_values"),
    ("remove_index", "ix_metadata_values_lookup"),
    ("remove_index", "ix_metadata_values_model"),
    ("modify_type", "descriptor_version"),
}


def _named(difference: Any) -> tuple[str, str]:
    if isinstance(difference, list):  # column changes come as a list of one
        (change,) = difference
        return change[0], change[3]
    return difference[0], difference[1].name


def test_the_migrated_schema_is_the_models_schema(database_url: str) -> None:
    engine = make_engine(database_url)
    try:
        upgrade(engine)
        with engine.connect() as connection:
            differences = compare_metadata(MigrationContext.configure(connection),
                                           Base.metadata)
    finally:
        engine.dispose()
    found = {_named(difference) for difference in differences}
    expected = _SQLITE_ONLY if engine.dialect.name == "sqlite" else _POSTGRESQL_ONLY
    assert found == expected
