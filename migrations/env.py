"""Alembic environment: runs online against the connection app.db.migrate hands over,
or, from the alembic CLI, against ``-x url=...`` / SHAPESEARCH_DATABASE_URL."""

from __future__ import annotations

from alembic import context
from sqlalchemy import Connection

from app.db.models import Base

config = context.config
target_metadata = Base.metadata


def _run(connection: Connection) -> None:
    context.configure(
        connection=connection,
        target_metadata=target_metadata,
        render_as_batch=connection.dialect.name == "sqlite",  # SQLite cannot ALTER much
        # SQLite's DDL is transactional, but Alembic does not assume it and commits after
        # each migration: a second process starting meanwhile took the lock between two,
        # ran the next migrations itself, and the first then ran them again and failed
        # (tests/test_migrations.py). One transaction for the whole upgrade, as on PostgreSQL.
        transactional_ddl=True,
    )
    with context.begin_transaction():
        context.run_migrations()


def run_migrations_online() -> None:
    connection = config.attributes.get("connection")
    if connection is not None:
        _run(connection)
        return

    from app.db.session import make_engine
    from app.settings import Settings

    url = context.get_x_argument(as_dictionary=True).get("url")
    engine = make_engine(url or Settings().resolved_database_url)
    with engine.connect() as new_connection:
        _run(new_connection)
        new_connection.commit()


if context.is_offline_mode():
    raise SystemExit("offline (--sql) migrations are not supported; run them online")
run_migrations_online()
