"""The job queue, kept in the ``jobs`` table of the service database.

A worker *claims* a due job, which gives it a lease: ``worker_id``, the ``attempts``
number of this claim and ``leased_until``. It renews the lease while it works and ends the
claim with exactly one of ``complete``, ``fail``, ``retry``, ``defer`` or ``release``. Every
one of those is guarded by (job id, worker id, attempts, status running): a worker whose
lease expired and was taken over changes nothing.

Claiming is one statement (``app.jobs.lease``), which also takes over jobs whose worker's
lease expired. Due jobs are claimed in turn order, so that tenants take turns
(``app.jobs.turns``: every job is queued by ``queue_job`` there).

A take-over counts as an attempt: the worker that held the job died (crashed, was
OOM-killed) while describing it, perhaps *because* of it. Before claiming, the same
transaction fails every expired job whose attempts are spent, with the reason "the worker
died N times while describing this file", so a poison file cannot loop forever.

A job is of a ``kind``: ``describe`` and ``redescribe`` describe one model's file (and
complete with ``complete``); ``duplicates`` computes a tenant's duplicates report from its
``params`` (no model; it completes with ``complete_report``). The worker dispatches on it.

Times come from the workers' clocks (UTC); hosts are expected to run NTP, and the lease is
long compared with any plausible skew.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Any

from sqlalchemy import and_, select, update
from sqlalchemy.orm import Session, sessionmaker

from app.db.feed import record_event
from app.db.models import Job, Model, Upload, utcnow
from app.db.session import rows_changed
from app.ingest.revisions import mark_revision_failed, promote, revision_content
from app.jobs.lease import backoff_seconds, claim_next
from app.problems import problem
from app.webhooks import record_model_event

__all__ = ["DUPLICATES", "Claim", "JobQueue", "worker_died_error"]

DUPLICATES = "duplicates"  # the kind of a duplicates report job


@dataclass(frozen=True)
class Claim:
    """One worker's hold on one job."""

    job_id: uuid.UUID
    model_id: uuid.UUID | None  # None: a job about no one model (a duplicates report)
    worker_id: str
    attempts: int
    kind: str = "describe"
    tenant: str = ""
    params: dict[str, Any] | None = None


def worker_died_error(attempts: int, kind: str = "describe") -> dict[str, str]:
    """The failure recorded for a job whose workers died on every attempt."""
    times = "once" if attempts == 1 else f"{attempts} times"
    doing = "computing the duplicates report" if kind == DUPLICATES else "describing this file"
    return problem("worker-died", f"the worker died {times} while {doing}")


class JobQueue:
    """Claim, renew and finish jobs; every method is one short transaction."""

    def __init__(
        self,
        sessions: sessionmaker[Session],
        *,
        lease_seconds: float,
        max_attempts: int,
        backoff_base: float = 5.0,
        backoff_cap: float = 300.0,
    ) -> None:
        self.sessions = sessions
        self.lease = timedelta(seconds=lease_seconds)
        self.max_attempts = max_attempts
        self.backoff_base = backoff_base
        self.backoff_cap = backoff_cap

    # --- claiming ---------------------------------------------------------------------

    def claim(self, worker_id: str) -> Claim | None:
        """Take the next due job (or one whose lease expired), or None if there is none."""
        now = utcnow()
        with self.sessions.begin() as session:
            self._fail_poison_jobs(session, now)
            row = claim_next(
                session, Job, waiting="queued", held="running", worker_id=worker_id, now=now,
                lease=self.lease,
                returning=(Job.id, Job.model_id, Job.attempts, Job.kind, Job.tenant, Job.params),
            )
            if row is None:
                return None
            if row.model_id is not None:
                session.execute(
                    update(Model)
                    .where(Model.id == row.model_id, Model.status != "ready")  # keeps serving
                    .values(status="processing", updated_at=now)
                )
        return Claim(
            job_id=row.id, model_id=row.model_id, worker_id=worker_id, attempts=row.attempts,
            kind=row.kind, tenant=row.tenant, params=row.params,
        )

    def _fail_poison_jobs(self, session: Session, now: datetime) -> None:
        """Fail the expired jobs whose workers died on every allowed attempt."""
        dead = session.execute(
            update(Job)
            .where(
                Job.status == "running",
                Job.leased_until < now,
                Job.attempts >= self.max_attempts,
            )
            .values(status="failed", leased_until=None, updated_at=now)
            .returning(Job.id, Job.model_id, Job.attempts, Job.kind)
        ).all()
        for job_id, model_id, attempts, kind in dead:
            error = worker_died_error(attempts, kind)
            session.execute(update(Job).where(Job.id == job_id).values(last_error=error))
            if model_id is None:
                continue
            session.execute(
                update(Model)
                .where(Model.id == model_id)
                .values(status="failed", error=error, updated_at=now)
            )

    def _held(self, claim: Claim) -> Any:
        """WHERE clause true only while ``claim`` still holds its job."""
        return and_(
            Job.id == claim.job_id,
            Job.status == "running",
            Job.worker_id == claim.worker_id,
            Job.attempts == claim.attempts,
        )

    def renew(self, claim: Claim) -> bool:
        """Extend the lease; False if the job was taken over, released or deleted."""
        now = utcnow()
        with self.sessions.begin() as session:
            result = session.execute(
                update(Job).where(self._held(claim)).values(leased_until=now + self.lease)
            )
            return rows_changed(result) == 1

    # --- ending a claim ---------------------------------------------------------------

    def complete(self, claim: Claim, result: dict[str, Any]) -> bool:
        """Store the description and mark the model ready, in one transaction.

        ``result`` holds the Model columns to write (descriptor, cutoff, ...). Returns False,
        writing nothing, when the claim no longer holds the job.
        """
        model_id = claim.model_id
        if model_id is None:
            raise ValueError("complete() stores a model's description; a report's job ends "
                             "with complete_report()")
        now = utcnow()
        with self.sessions.begin() as session:
            if not self._mark_done(session, claim, now):
                return False
            promote(session, claim.job_id, model_id)  # a new revision's file, if any
            index_id, tenant = session.execute(
                update(Model)
                .where(Model.id == model_id)
                .values(status="ready", error=None, updated_at=now, **result)
                .returning(Model.index_id, Model.tenant)
            ).one()
            record_event(session, index_id, "ready", tenant)
            record_model_event(session, model_id, "model.ready", claim.job_id)
        return True

    def complete_report(self, claim: Claim, store: Callable[[Session], object]) -> bool:
        """Mark a job about no one model done and ``store`` its result, in one transaction;
        False, storing nothing, when the claim no longer holds the job."""
        with self.sessions.begin() as session:
            if not self._mark_done(session, claim, utcnow()):
                return False
            store(session)
        return True

    def _mark_done(self, session: Session, claim: Claim, now: datetime) -> bool:
        """Mark the claimed job done in ``session``; False when the claim no longer holds it."""
        done = session.execute(
            update(Job)
            .where(self._held(claim))
            .values(status="done", leased_until=None, last_error=None, updated_at=now)
        )
        return rows_changed(done) == 1

    def fail(self, claim: Claim, error: dict[str, Any]) -> bool:
        """Give up on the job: the model is failed with ``error`` ({type, title, detail})."""
        now = utcnow()
        with self.sessions.begin() as session:
            failed = session.execute(
                update(Job)
                .where(self._held(claim))
                .values(status="failed", leased_until=None, last_error=error, updated_at=now)
            )
            if rows_changed(failed) != 1:
                return False
            if claim.model_id is None:
                return True
            # A ready model whose re-describe failed keeps its descriptor and stays ready.
            session.execute(
                update(Model)
                .where(Model.id == claim.model_id, Model.status != "ready")
                .values(status="failed", error=error, updated_at=now)
            )
            mark_revision_failed(session, claim.job_id)
            record_model_event(session, claim.model_id, "model.failed", claim.job_id)
        return True

    def retry(self, claim: Claim, error: dict[str, Any]) -> bool:
        """Put the job back with exponential backoff, or fail it when attempts are spent."""
        if claim.attempts >= self.max_attempts:
            return self.fail(claim, error)
        now = utcnow()
        delay = backoff_seconds(claim.attempts, self.backoff_base, self.backoff_cap)
        return self._requeue(
            claim, now, run_after=now + timedelta(seconds=delay), last_error=error
        )

    def defer(self, claim: Claim, error: dict[str, Any], seconds: float) -> bool:
        """Put the job back for ``seconds`` with ``error`` shown, this attempt not counted:
        the machine, not the job, is at fault (storage full)."""
        now = utcnow()
        return self._requeue(
            claim, now, run_after=now + timedelta(seconds=seconds),
            attempts=Job.attempts - 1, last_error=error,
        )

    def release(self, claim: Claim) -> bool:
        """Hand the job back untouched (shutdown): due at once, this attempt not counted."""
        now = utcnow()
        return self._requeue(claim, now, run_after=now, attempts=Job.attempts - 1)

    def _requeue(self, claim: Claim, now: datetime, **job_values: Any) -> bool:
        """Queue a held job again (its model with it); False if the lease was lost."""
        with self.sessions.begin() as session:
            queued = session.execute(
                update(Job)
                .where(self._held(claim))
                .values(
                    status="queued", leased_until=None, worker_id=None, updated_at=now,
                    **job_values,
                )
            )
            if rows_changed(queued) != 1:
                return False
            if claim.model_id is not None:
                session.execute(
                    update(Model)
                    .where(Model.id == claim.model_id, Model.status != "ready")
                    .values(status="queued", updated_at=now)
                )
        return True

    # --- reading ----------------------------------------------------------------------

    def upload_of(self, claim: Claim) -> tuple[bytes, str] | None:
        """The uploaded bytes and file name of the claimed model (None if it was deleted)."""
        with self.sessions() as session:
            pending = revision_content(session, claim.job_id)
            if pending is not None:
                return pending
            row = session.execute(
                select(Upload.content, Model.file_name)
                .join(Model, Model.id == Upload.model_id)
                .where(Upload.model_id == claim.model_id)
            ).one_or_none()
        return None if row is None else (bytes(row.content), row.file_name)
