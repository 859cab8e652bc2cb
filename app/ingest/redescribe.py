"""Re-describe: move a database's models to the current engine settings.

Models keep the descriptor_version they were described with; only models at the current
version are compared by POST /v1/search. It queues a re-describe job (from the
stored original) for the chosen models; workers run them, and each model keeps serving its
old descriptor until the new one replaces it (``app.ingest.revisions``). The command is
``shapesearch redescribe`` (``app.cli.redescribe``).
"""

from __future__ import annotations

import uuid

from sqlalchemy import ColumnElement, func, select
from sqlalchemy.orm import Session, sessionmaker

from app.db.models import Model
from app.ingest.describing import descriptor_version
from app.ingest.revisions import enqueue_redescribe, lock_models
from app.settings import Settings, engine_settings

__all__ = ["current_version", "enqueue_models"]


def current_version(settings: Settings) -> str:
    """The descriptor_version the service's settings produce."""
    return descriptor_version(engine_settings(settings))


def enqueue_models(
    sessions: sessionmaker[Session], *, from_version: str | None, everything: bool,
    current: str,
) -> list[uuid.UUID]:
    """Queue a job per chosen model; returns the job ids. Default choice: every model not
    failed whose descriptor_version differs from ``current``. The jobs are background jobs:
    each tenant's uploads keep taking turns with them (``app.jobs.turns``)."""
    where: list[ColumnElement[bool]]
    if everything:
        where = [Model.id.is_not(None)]
    elif from_version is not None:
        where = [Model.descriptor_version == from_version]
    else:
        where = [
            Model.status == "ready",
            func.coalesce(Model.descriptor_version, "") != current,
        ]
    job_ids: list[uuid.UUID] = []
    with sessions.begin() as session:
        locked = lock_models(session, *where)
        for model in session.scalars(select(Model).where(Model.id.in_(locked))):
            job_ids.append(enqueue_redescribe(session, model, background=True).id)
    return job_ids

