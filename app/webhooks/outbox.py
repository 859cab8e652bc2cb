"""The webhook outbox: one delivery row per subscribed endpoint, written inside the
transaction that makes the change (the change and its event commit together); settled
deliveries queued again on request (``requeue``)."""

from __future__ import annotations

import uuid
from datetime import datetime
from typing import Any

from sqlalchemy import insert, select, update
from sqlalchemy.orm import Session

from app.db.doorbells import WEBHOOKS, announce
from app.db.models import Job, Model, Webhook, WebhookDelivery, utcnow
from app.db.session import one_at_a_time
from app.jobs.turns import next_turn
from app.webhooks.delivery import CLAIMS

__all__ = ["EVENT_TYPES", "record_model_event", "requeue"]

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


def requeue(
    session: Session, webhook_id: uuid.UUID, *, delivery_id: uuid.UUID | None = None,
    since: datetime | None = None,
) -> list[uuid.UUID]:
    """Queue settled deliveries of an endpoint again: the one ``delivery_id`` (delivered or
    failed), or else every failed one created at or after ``since`` (None: every failed one
    still kept). Returns their ids, oldest first.

    Each keeps its id (the ``webhook-id`` a receiver deduplicates on) and payload, starts a
    new round of up to ``SHAPESEARCH_WEBHOOK_MAX_ATTEMPTS`` attempts (its log numbers them
    from 1 again) at once, and takes the endpoint's next turns in the order the events were
    created. The claims' lock comes first: no claim reads the endpoint half requeued, and on
    SQLite the transaction begins with the write lock (``app.db.session.one_at_a_time``).
    """
    one_at_a_time(session, CLAIMS)
    query = select(WebhookDelivery.id).where(WebhookDelivery.webhook_id == webhook_id)
    if delivery_id is not None:
        query = query.where(WebhookDelivery.id == delivery_id,
                            WebhookDelivery.status.in_(("delivered", "failed")))
    else:
        query = query.where(WebhookDelivery.status == "failed")
        if since is not None:
            query = query.where(WebhookDelivery.created_at >= since)
    ids = list(session.scalars(query.order_by(WebhookDelivery.created_at, WebhookDelivery.id)))
    if not ids:
        return []
    first = next_turn(session, WebhookDelivery, [WebhookDelivery.webhook_id == webhook_id],
                      waiting="pending")
    now = utcnow()
    session.execute(update(WebhookDelivery), [
        {"id": queued, "status": "pending", "attempts": 0, "run_after": now, "turn": first + n,
         "leased_until": None, "worker_id": None, "updated_at": now}
        for n, queued in enumerate(ids)
    ])
    announce(session, WEBHOOKS)
    return ids
