"""``shapesearch redescribe``: move a database to the current engine settings.

Models keep the descriptor_version they were described with; only models at the current
version are compared by POST /v1/search. This command queues a re-describe job (from the
stored original) for the chosen models; workers run them, and each model keeps serving its
old descriptor until the new one replaces it (app/revisions.py). With ``--wait`` a progress
bar follows the jobs to the end.
"""

from __future__ import annotations

import sys
import time
import uuid

from sqlalchemy import func, select
from sqlalchemy.orm import Session, sessionmaker

from app.db.models import Job, Model
from app.describing import descriptor_version
from app.revisions import enqueue_redescribe, lock_models
from app.settings import Settings, engine_settings

__all__ = ["current_version", "enqueue_models", "redescribe_command"]


def current_version(settings: Settings) -> str:
    """The descriptor_version the service's settings produce."""
    return descriptor_version(engine_settings(settings))


def enqueue_models(
    sessions: sessionmaker[Session], *, from_version: str | None, everything: bool,
    current: str,
) -> list[uuid.UUID]:
    """Queue a job per chosen model; returns the job ids. Default choice: every model not
    failed whose descriptor_version differs from ``current``."""
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
            job_ids.append(enqueue_redescribe(session, model).id)
    return job_ids


def _follow(sessions: sessionmaker[Session], job_ids: list[uuid.UUID]) -> int:
    from tqdm import tqdm

    failed = 0
    with tqdm(total=len(job_ids), unit="model", desc="redescribe") as bar:
        done = 0
        while done < len(job_ids):
            with sessions() as session:
                counts = dict(
                    session.execute(
                        select(Job.status, func.count())
                        .where(Job.id.in_(job_ids))
                        .group_by(Job.status)
                    ).all()
                )
            finished = counts.get("done", 0) + counts.get("failed", 0)
            failed = counts.get("failed", 0)
            bar.update(finished - done)
            bar.set_postfix(failed=failed, running=counts.get("running", 0))
            done = finished
            if done < len(job_ids):
                time.sleep(1.0)
    return failed


def redescribe_command(*, from_version: str | None, everything: bool, wait: bool) -> int:
    from app.db.migrate import upgrade
    from app.db.session import make_engine, make_session_factory

    settings = Settings()
    engine = make_engine(settings.resolved_database_url)
    upgrade(engine)
    sessions = make_session_factory(engine)
    current = current_version(settings)
    job_ids = enqueue_models(
        sessions, from_version=from_version, everything=everything, current=current
    )
    print(f"queued {len(job_ids)} re-describe job(s) towards {current}", file=sys.stderr)
    if not wait or not job_ids:
        return 0
    failed = _follow(sessions, job_ids)
    print(f"done: {len(job_ids) - failed} re-described, {failed} failed", file=sys.stderr)
    return 1 if failed else 0
