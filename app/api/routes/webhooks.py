"""/v1/webhooks: a tenant's endpoints for model.ready, model.failed and model.deleted,
the delivery log of each, and sending deliveries again (see app/webhooks/ for signing and
delivery)."""

from __future__ import annotations

import uuid
from collections.abc import Sequence
from datetime import datetime
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Query, Response
from pydantic import BaseModel, Field
from sqlalchemy import delete, select

from app.api.deps import ServicesDep, SessionDep
from app.api.problems import Problem, problem_responses
from app.auth.dependency import TenantDep
from app.db.models import Webhook, WebhookAttempt, WebhookDelivery
from app.webhooks import (
    TargetRefused,
    check_target,
    new_secret,
    recover,
    requeue,
    valid_secret,
)

__all__ = ["router"]

router = APIRouter(prefix="/v1", tags=["webhooks"])

EventType = Literal["model.ready", "model.failed", "model.deleted"]


# What the service checks, stated in the document (app/webhooks checks it, with its own
# problem types): http(s), a host, no credentials; whsec_ and base64 of >= 16 bytes. Whether
# the host resolves, and to a public address, JSON Schema cannot say: that 422 is
# webhook-url-refused.
_URL_PATTERN = r"^https?://[^/?#@\s]+([/?#][^\x00]*)?$"
_SECRET_PATTERN = (
    r"^(whsec_)?(?=[A-Za-z0-9+/]{22})([A-Za-z0-9+/]{4})*([A-Za-z0-9+/]{2}(==)?|[A-Za-z0-9+/]{3}=?)?$"
)


class WebhookCreate(BaseModel):
    url: str = Field(
        max_length=2000,
        description="http(s) URL that receives the POSTs, without credentials. Its host must "
        "resolve, and to public addresses unless SHAPESEARCH_WEBHOOK_ALLOW_PRIVATE=true "
        "(else 422 webhook-url-refused).",
        json_schema_extra={"format": "uri", "pattern": _URL_PATTERN},
    )
    events: list[EventType] = Field(min_length=1)
    secret: str | None = Field(
        default=None,
        max_length=200,
        description="Standard Webhooks secret (whsec_ + base64, >= 16 bytes); generated "
        "and shown once when absent.",
        json_schema_extra={"pattern": _SECRET_PATTERN},
    )


class WebhookResource(BaseModel):
    id: uuid.UUID
    url: str
    events: list[EventType]
    created_at: datetime


class WebhookCreated(WebhookResource):
    secret: str = Field(description="Shown only in this answer: store it to verify signatures.")


class WebhookList(BaseModel):
    items: list[WebhookResource]


class AttemptResource(BaseModel):
    attempt: int
    status_code: int | None = Field(description="The receiver's status; null: no answer.")
    error: str | None
    duration_ms: float
    created_at: datetime


class DeliveryResource(BaseModel):
    id: uuid.UUID = Field(description="The webhook-id header, the same on every attempt.")
    event_type: EventType
    status: Literal["pending", "sending", "delivered", "failed"]
    attempts: list[AttemptResource]
    payload: dict[str, Any]
    next_attempt_at: datetime | None
    created_at: datetime


class DeliveryList(BaseModel):
    items: list[DeliveryResource] = Field(description="Newest first.")


def _resource(hook: Webhook) -> WebhookResource:
    return WebhookResource(
        id=hook.id, url=hook.url, events=hook.events, created_at=hook.created_at  # type: ignore[arg-type]
    )


def _load(session: Any, tenant: str, webhook_id: str) -> Webhook:
    try:
        parsed = uuid.UUID(webhook_id)
    except ValueError:
        parsed = None
    hook = (
        session.scalar(select(Webhook).where(Webhook.id == parsed, Webhook.tenant == tenant))
        if parsed is not None
        else None
    )
    if hook is None:
        raise Problem("webhook-not-found", f"There is no webhook {webhook_id}.")
    return hook


@router.post(
    "/webhooks",
    status_code=201,
    response_model=WebhookCreated,
    responses=problem_responses(401, 422),
    summary="Register an endpoint for model events",
)
def create_webhook(
    body: WebhookCreate, response: Response, tenant: TenantDep, services: ServicesDep
) -> WebhookCreated:
    try:
        check_target(body.url, allow_private=services.settings.webhook_allow_private)
    except TargetRefused as error:
        raise Problem("webhook-url-refused", f"Webhook URL refused: {error}.") from None
    if body.secret is not None and not valid_secret(body.secret):
        raise Problem(
            "invalid-webhook-secret",
            "secret must be whsec_ followed by base64 of at least 16 random bytes.",
        )
    secret = body.secret or new_secret()
    hook = Webhook(
        id=uuid.uuid4(), tenant=tenant, url=body.url, events=sorted(set(body.events)),
        secret=secret,
    )
    with services.sessions.begin() as session:
        session.add(hook)
        session.flush()
        created = WebhookCreated(**_resource(hook).model_dump(), secret=secret)
    response.headers["Location"] = f"/v1/webhooks/{hook.id}"
    return created


@router.get(
    "/webhooks",
    response_model=WebhookList,
    responses=problem_responses(401),
    summary="The tenant's endpoints",
)
def list_webhooks(tenant: TenantDep, session: SessionDep) -> WebhookList:
    hooks = session.scalars(
        select(Webhook).where(Webhook.tenant == tenant).order_by(Webhook.created_at)
    ).all()
    return WebhookList(items=[_resource(hook) for hook in hooks])


@router.get(
    "/webhooks/{webhook_id}",
    response_model=WebhookResource,
    responses=problem_responses(401, 404),
    summary="One endpoint",
)
def get_webhook(webhook_id: str, tenant: TenantDep, session: SessionDep) -> WebhookResource:
    return _resource(_load(session, tenant, webhook_id))


@router.delete(
    "/webhooks/{webhook_id}",
    status_code=204,
    response_class=Response,
    responses=problem_responses(401, 404),
    summary="Remove an endpoint; its pending deliveries are dropped",
)
def delete_webhook(webhook_id: str, tenant: TenantDep, services: ServicesDep) -> Response:
    try:
        parsed = uuid.UUID(webhook_id)
    except ValueError:
        parsed = None
    with services.sessions.begin() as session:
        deleted = session.scalar(
            delete(Webhook)
            .where(Webhook.id == parsed, Webhook.tenant == tenant)
            .returning(Webhook.id)
        )
    if deleted is None:
        raise Problem("webhook-not-found", f"There is no webhook {webhook_id}.")
    return Response(status_code=204)


@router.get(
    "/webhooks/{webhook_id}/deliveries",
    response_model=DeliveryList,
    responses=problem_responses(401, 404),
    summary="The endpoint's deliveries with every attempt, newest first",
)
def list_deliveries(
    webhook_id: str,
    tenant: TenantDep,
    session: SessionDep,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
) -> DeliveryList:
    hook = _load(session, tenant, webhook_id)
    deliveries = session.scalars(
        select(WebhookDelivery)
        .where(WebhookDelivery.webhook_id == hook.id)
        .order_by(WebhookDelivery.created_at.desc(), WebhookDelivery.id)
        .limit(limit)
    ).all()
    return DeliveryList(items=_delivery_resources(session, deliveries))


class Recovery(BaseModel):
    since: datetime | None = Field(
        default=None,
        description="Only failed deliveries created at or after this time (ISO 8601; without "
        "a zone: UTC). Absent or null: every failed delivery still kept "
        "(SHAPESEARCH_HISTORY_DAYS).",
    )


class Recovered(BaseModel):
    requeued: int = Field(description="Failed deliveries queued again.")


@router.post(
    "/webhooks/{webhook_id}/recover",
    status_code=202,
    response_model=Recovered,
    responses=problem_responses(401, 404, 422),
    summary="Queue the endpoint's failed deliveries again",
    description="For a receiver that was away longer than the retries last "
    "(SHAPESEARCH_WEBHOOK_MAX_ATTEMPTS attempts, backing off to "
    "SHAPESEARCH_WEBHOOK_BACKOFF_MAX_SECONDS): every failed delivery (since `since`) is sent "
    "again, oldest first, one at a time, each with a new round of attempts and its own "
    "webhook-id, so a receiver that did get one deduplicates it.",
)
def recover_deliveries(
    webhook_id: str, body: Recovery, tenant: TenantDep, session: SessionDep,
    services: ServicesDep,
) -> Recovered:
    hook = _load(session, tenant, webhook_id)
    return Recovered(requeued=recover(services.sessions, hook.id, body.since))


@router.post(
    "/webhooks/{webhook_id}/deliveries/{delivery_id}/retry",
    status_code=202,
    response_model=DeliveryResource,
    responses=problem_responses(401, 404),
    summary="Send one delivery again",
    description="A delivered or failed delivery is queued again with a new round of "
    "attempts and the same webhook-id; one still pending or being sent is answered as it is.",
)
def retry_delivery(
    webhook_id: str, delivery_id: str, tenant: TenantDep, session: SessionDep,
    services: ServicesDep,
) -> DeliveryResource:
    hook = _load(session, tenant, webhook_id)
    missing = Problem("delivery-not-found",
                      f"The webhook {webhook_id} has no delivery {delivery_id}.")
    try:
        parsed = uuid.UUID(delivery_id)
    except ValueError:
        raise missing from None
    with services.sessions.begin() as writing:  # requeue's lock comes first in it
        requeue(writing, hook.id, parsed)
        delivery = writing.scalar(select(WebhookDelivery).where(
            WebhookDelivery.id == parsed, WebhookDelivery.webhook_id == hook.id
        ))
        if delivery is None:
            raise missing
        return _delivery_resources(writing, [delivery])[0]


def _delivery_resources(
    session: Any, deliveries: Sequence[WebhookDelivery]
) -> list[DeliveryResource]:
    """``deliveries`` with their attempt logs, each in the order the attempts were made."""
    attempts: dict[uuid.UUID, list[AttemptResource]] = {d.id: [] for d in deliveries}
    if deliveries:
        for row in session.scalars(
            select(WebhookAttempt)
            .where(WebhookAttempt.delivery_id.in_(list(attempts)))
            .order_by(WebhookAttempt.id)  # a delivery sent again numbers its attempts anew
        ):
            attempts[row.delivery_id].append(
                AttemptResource(
                    attempt=row.attempt, status_code=row.status_code, error=row.error,
                    duration_ms=row.duration_ms, created_at=row.created_at,
                )
            )
    return [
        DeliveryResource(
            id=d.id,
            event_type=d.event_type,  # type: ignore[arg-type]
            status=d.status,  # type: ignore[arg-type]
            attempts=attempts[d.id],
            payload=d.payload,
            next_attempt_at=d.run_after if d.status == "pending" else None,
            created_at=d.created_at,
        )
        for d in deliveries
    ]
