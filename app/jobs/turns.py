"""Turns: one owner's backlog does not hold up another owner's work.

Two queues are claimed under a lease (``app.jobs.lease``): jobs, owned by tenants, and webhook
deliveries, owned by endpoints. Both were claimed oldest first, so when one tenant imported a
thousand files every other tenant's upload waited until all of them were described (a
100-file import held another tenant's upload 40x its idle time, ``bench/queue_fairness.py``),
and an endpoint that hung with a backlog of events held every other endpoint's events for its
timeout per event. Each row now gets a *turn* when it is queued, and due rows are claimed in
turn order, oldest first within a turn:

* an owner's next row takes the turn after that owner's last waiting row, so an owner's rows
  keep their order and take one turn each;
* but never a turn before the queue's head (the least turn among due waiting rows, or among
  all waiting rows when none is due), so an owner that had nothing waiting joins at the
  head: its row waits for at most one row of each owner with a backlog, not for the whole
  backlog.

A job's owner is its tenant and whether it is part of a bulk load (``Job.background``: an
upload sent with background=true, as ``shapesearch import`` sends them, or the operator's
re-describe of a whole catalogue). So a tenant's uploads and its bulk load take turns like
two tenants, and an upload waits for at most one job of the load, not the whole load (with
one tenant, a re-describe of 104 models held an upload 58x its idle time, now 1.1x,
``bench/bulk_fairness.py``). A tenant with both backlogs takes two turns a round;
that is the price of parking neither.

This is start-time fair queuing with every row costing one turn: backlogged owners are served
round-robin, a row at a time, whatever their backlog. A row retried or put back keeps its
turn (it stays near the front, gated by its ``run_after``); the head counts only due rows, so
a row waiting out a back-off does not hold the head back and let newcomers queue ahead of the
round. Two API replicas queueing rows of one owner at once may give both the same turn; the
tie is broken by age. Each read is an index seek (``ix_jobs_claim``, ``ix_jobs_tenant_turn``;
``ix_webhook_deliveries_claim``, ``ix_webhook_deliveries_endpoint_turn``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from sqlalchemy import ColumnElement, func, select
from sqlalchemy.orm import Session

from app.db.doorbells import JOBS, announce
from app.db.models import Job, utcnow

__all__ = ["next_turn", "queue_job"]


def next_turn(
    session: Session, table: Any, owner: Sequence[ColumnElement[bool]], *, waiting: str
) -> int:
    """The turn of a new row of ``table`` (``Job`` or ``WebhookDelivery``) whose owner's
    rows ``owner`` selects (e.g. ``[WebhookDelivery.webhook_id == hook_id]``): after that
    owner's last row in status ``waiting``, not before the head."""
    rows_waiting = select(func.min(table.turn)).where(table.status == waiting)
    head = session.scalar(
        select(func.coalesce(  # with no row due, the least waiting turn is the head
            rows_waiting.where(table.run_after <= utcnow()).scalar_subquery(),
            rows_waiting.scalar_subquery(),
        ))
    )
    last = session.scalar(
        select(func.max(table.turn)).where(*owner, table.status == waiting)
    )
    return max(head or 0, -1 if last is None else last + 1)


def queue_job(
    session: Session, *, tenant: str, background: bool = False, **columns: Any
) -> Job:
    """A new queued job of ``tenant`` with its turn, added to ``session`` and flushed;
    the session's commit wakes idle workers (``app.db.doorbells``).

    ``background``: part of a bulk load (its own turns, see above); ``columns``: the other
    ``Job`` columns.
    """
    owner = [Job.tenant == tenant, Job.background == background]
    job = Job(tenant=tenant, background=background, status="queued", attempts=0,
              turn=next_turn(session, Job, owner, waiting="queued"), **columns)
    session.add(job)
    session.flush()
    announce(session, JOBS)
    return job
