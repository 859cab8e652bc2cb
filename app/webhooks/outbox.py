"""The webhook outbox: one delivery row per subscribed endpoint, written inside the
transaction that makes the change (the change and its event commit together); settled
deliveries queued again on request (``requeue`` one, ``recover`` an endpoint's failed ones)."""

from __future__ import annotations

import time
import uuid
from datetime import datetime
from typing import Any

from sqlalchemy import ColumnElement, insert, select, tuple_, update
from sqlalchemy.orm import Session, sessionmaker

from app.db.doorbells import WEBHOOKS, announce
from app.db.models import Job, Model, Webhook, WebhookDelivery, utcnow
from app.db.session import one_at_a_time, pause_for_writers
from app.jobs.turns import next_turn
from app.webhooks.delivery import CLAIMS

__all__ = ["EVENT_TYPES", "record_model_event", "recover", "requeue"]

EVENT_TYPES = ("model.ready", "model.failed", "model.deleted")


def _model_data(session: Session, model_id: uuid.UUID) -> tuple[str, dict[str, Any]] | None:
    model = session.scalar(select(Model).where(Model.id == model_id))
    if model is None:
        return None
    return model.tenant, {
        "id": str(model.id),
        "external_id": model.external_id,
        "name": model.name,
        "status": model.status,
        "descriptor_version": model.descriptor_version,
        "error": model.error,
    }


def record_model_event(
    session: Session, model_id: uuid.UUID, event_type: str, job_id: uuid.UUID | None = None
) -> int:
    """Queue ``event_type`` about a model for every endpoint of its tenant that wants it.

    Call it inside the transaction that makes the change (for deletes: before the delete).
    Returns the number of deliveries written.
    """
    found = _model_data(session, model_id)
    if found is None:
        return 0
    tenant, model = found
    endpoints = [
        hook.id
        for hook in session.scalars(select(Webhook).where(Webhook.tenant == tenant))
        if event_type in hook.events
    ]
    if not endpoints:
        return 0
    data: dict[str, Any] = {"model": model}
    if job_id is not None:
        job = session.get(Job, job_id)
        if job is not None:
            data["job"] = {
                "id": str(job.id), "status": job.status, "attempts": job.attempts,
                "error": job.last_error,
            }
    now = utcnow()
    payload = {"type": event_type, "timestamp": now.isoformat(), "data": data}
    session.execute(
        insert(WebhookDelivery),
        [
            {
                "id": uuid.uuid4(), "webhook_id": hook_id, "event_type": event_type,
                "payload": payload, "status": "pending", "attempts": 0, "run_after": now,
                "created_at": now, "updated_at": now,
                # Endpoints take turns: one that hangs with a backlog delays another
                # endpoint's event by at most one attempt (app.jobs.turns).
                "turn": next_turn(session, WebhookDelivery,
                                  [WebhookDelivery.webhook_id == hook_id], waiting="pending"),
            }
            for hook_id in endpoints
        ],
    )
    announce(session, WEBHOOKS)  # the deliverers send it once the change commits
    return len(endpoints)


def requeue(session: Session, webhook_id: uuid.UUID, delivery_id: uuid.UUID) -> bool:
    """Queue one delivered or failed delivery of an endpoint again; False if the endpoint
    has no such settled delivery (``_requeue`` says how)."""
    settled = WebhookDelivery.status.in_(("delivered", "failed"))
    return bool(_requeue(session, webhook_id, [WebhookDelivery.id == delivery_id, settled]))


def recover(
    sessions: sessionmaker[Session], webhook_id: uuid.UUID, since: datetime | None = None,
    *, batch: int = 1000,
) -> int:
    """Queue every failed delivery of an endpoint again, created at or after ``since``
    (None: every failed one still kept), oldest first; returns how many.

    ``batch`` per transaction, paced (``app.db.session.pause_for_writers``): in one
    transaction, 10^5 failed deliveries held SQLite's write lock for 6.6 s, and an upload
    waited as long (``bench/webhook_recover.py``). A delivery that fails again meanwhile is
    not taken twice (only those last changed before the call are), and each batch starts
    after the last one's last delivery.
    """
    began = utcnow()
    count, after = 0, None
    while True:
        started = time.monotonic()
        where = [WebhookDelivery.status == "failed", WebhookDelivery.updated_at < began]
        if since is not None:
            where.append(WebhookDelivery.created_at >= since)
        if after is not None:
            where.append(tuple_(WebhookDelivery.created_at, WebhookDelivery.id) > after)
        with sessions.begin() as session:
            queued = _requeue(session, webhook_id, where, limit=batch)
        count += len(queued)
        if len(queued) < batch:
            return count
        after = tuple_(*queued[-1])
        pause_for_writers(started)


def _requeue(
    session: Session, webhook_id: uuid.UUID, where: list[ColumnElement[bool]],
    limit: int | None = None,
) -> list[tuple[datetime, uuid.UUID]]:
    """Queue the endpoint's deliveries that ``where`` selects (at most ``limit``) again;
    their (created_at, id), oldest first.

    Each keeps its id (the ``webhook-id`` a receiver deduplicates on) and payload, starts a
    new round of up to ``SHAPESEARCH_WEBHOOK_MAX_ATTEMPTS`` attempts (its log numbers them
    from 1 again) at once, and takes the endpoint's next turns in the order the events were
    created. The claims' lock comes first: no claim reads the endpoint half requeued, and on
    SQLite the transaction begins with the write lock (``app.db.session.one_at_a_time``).
    """
    one_at_a_time(session, CLAIMS)
    rows = session.execute(
        select(WebhookDelivery.created_at, WebhookDelivery.id)
        .where(WebhookDelivery.webhook_id == webhook_id, *where)
        .order_by(WebhookDelivery.created_at, WebhookDelivery.id)
        .limit(limit)
    ).all()
    if not rows:
        return []
    first = next_turn(session, WebhookDelivery, [WebhookDelivery.webhook_id == webhook_id],
                      waiting="pending")
    now = utcnow()
    session.execute(update(WebhookDelivery), [
        {"id": row.id, "status": "pending", "attempts": 0, "run_after": now,
         "turn": first + n, "leased_until": None, "worker_id": None, "updated_at": now}
        for n, row in enumerate(rows)
    ])
    announce(session, WEBHOOKS)
    return [(row.created_at, row.id) for row in rows]
