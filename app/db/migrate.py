"""Apply the Alembic migrations shipped inside the ``migrations`` package.

Run at start-up by every process; concurrent start-ups take turns instead of racing to
create the same tables: on PostgreSQL by an advisory lock, on SQLite by taking the write lock
at the migration's BEGIN (Alembic reads the schema before it writes, and on SQLite a
transaction that read first cannot take the lock once another process committed: of two
processes started at once after an upgrade, one died with "database is locked"), and
holding it to the end: the whole upgrade is one transaction (``migrations/env.py``).
"""

from __future__ import annotations

from pathlib import Path

from alembic import command
from alembic.config import Config
from alembic.runtime.migration import MigrationContext
from alembic.script import ScriptDirectory
from sqlalchemy import Engine, text

import migrations

__all__ = ["WRITE_FIRST", "alembic_config", "is_at_head", "upgrade"]

# Execution option of a SQLite connection whose transactions take the write lock at BEGIN
# (``app.db.session``).
WRITE_FIRST = "shapesearch_write_first"

_MIGRATION_LOCK = 0x5348_4150  # arbitrary, constant: "SHAP"


def alembic_config() -> Config:
    package = Path(migrations.__file__).parent
    config = Config(str(package / "alembic.ini"))
    config.set_main_option("script_location", str(package))
    return config


def upgrade(engine: Engine, revision: str = "head") -> None:
    """Bring the database schema to ``revision``, by default the latest."""
    config = alembic_config()
    with engine.connect() as connection:
        connection.execution_options(**{WRITE_FIRST: True})  # SQLite's; ignored elsewhere
        postgres = connection.dialect.name == "postgresql"
        if postgres:
            connection.execute(text("SELECT pg_advisory_lock(:k)"), {"k": _MIGRATION_LOCK})
            connection.commit()
        try:
            config.attributes["connection"] = connection
            command.upgrade(config, revision)
            connection.commit()
        finally:
            if postgres:
                connection.execute(text("SELECT pg_advisory_unlock(:k)"), {"k": _MIGRATION_LOCK})
                connection.commit()


def is_at_head(engine: Engine) -> bool:
    """Whether the database is at the newest migration this code knows."""
    head = ScriptDirectory.from_config(alembic_config()).get_current_head()
    with engine.connect() as connection:
        current = MigrationContext.configure(connection).get_current_revision()
    return current == head
