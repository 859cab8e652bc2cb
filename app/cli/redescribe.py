"""``shapesearch redescribe [--from-version V | --all] [--wait]``: queue re-describe jobs
towards the current engine settings; with ``--wait`` a progress bar follows them."""

from __future__ import annotations

import sys
import time
import uuid

from sqlalchemy import func, select
from sqlalchemy.orm import Session, sessionmaker
from tqdm import tqdm

from app.db.models import Job
from app.db.session import open_sessions
from app.ingest.redescribe import current_version, enqueue_models
from app.settings import Settings

__all__ = ["run"]


def run(*, from_version: str | None, everything: bool, wait: bool) -> int:
    """Queue the jobs; exit 1 when waited-for jobs failed."""
    settings = Settings()
    sessions = open_sessions(settings.resolved_database_url)
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


def _follow(sessions: sessionmaker[Session], job_ids: list[uuid.UUID]) -> int:
    """Poll the jobs' statuses once a second until all finished; returns how many failed."""
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
