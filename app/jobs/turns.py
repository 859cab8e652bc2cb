"""Turns among tenants: one tenant's backlog does not hold up another tenant's uploads.

Jobs were claimed oldest first, so when one tenant imported a thousand files every other
tenant's upload waited until all of them were described (a 100-file import held another
tenant's upload 40x its idle time, ``bench/queue_fairness.py``). Each job now gets a *turn*
when it is queued, and workers claim due jobs in turn order, oldest first within a turn
(``app.jobs.lease``):

* a tenant's next job takes the turn after that tenant's last queued job, so a tenant's jobs
  keep their order and take one turn each;
* but never a turn before the queue's head (the least turn among due queued jobs, or among
  all queued jobs when none is due), so a tenant that had nothing queued joins at the head:
  its job waits for at most one job of each tenant with a backlog, not for the whole backlog.

This is start-time fair queuing with every job costing one turn: backlogged tenants are
served round-robin, a job at a time, whatever their backlog. A job retried or put back keeps
its turn (it stays near the front, gated by its ``run_after``); the head counts only due
jobs, so a job waiting out a back-off does not hold the head back and let newcomers queue
ahead of the round. Two API replicas queueing jobs of one tenant at once may give both the
same turn; the tie is broken by age. Each read is an index seek (``ix_jobs_claim``,
``ix_jobs_tenant_turn``).
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.db.models import Job, utcnow

__all__ = ["queue_job"]


def next_turn(session: Session, tenant: str) -> int:
    """The turn of ``tenant``'s next job: after its last queued job, not before the head."""
    queued = select(func.min(Job.turn)).where(Job.status == "queued")
    head = session.scalar(
        select(func.coalesce(  # with no job due, the least queued turn is the head
            queued.where(Job.run_after <= utcnow()).scalar_subquery(),
            queued.scalar_subquery(),
        ))
    )
    last = session.scalar(
        select(func.max(Job.turn)).where(Job.tenant == tenant, Job.status == "queued")
    )
    return max(head or 0, -1 if last is None else last + 1)


def queue_job(session: Session, *, tenant: str, **columns: Any) -> Job:
    """A new queued job of ``tenant`` with its turn (``columns``: the other ``Job``
    columns), added to ``session`` and flushed."""
    job = Job(tenant=tenant, status="queued", attempts=0, turn=next_turn(session, tenant),
              **columns)
    session.add(job)
    session.flush()
    return job
