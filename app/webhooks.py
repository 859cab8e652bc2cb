"""Signed webhooks: the event outbox, the target rules and the deliverer.

    record_model_event  writes one delivery row per subscribed endpoint, inside the caller's
                        transaction (the change and its event commit together: the outbox)
    check_target        http(s) only; private, loopback and link-local addresses refused
                        unless SHAPESEARCH_WEBHOOK_ALLOW_PRIVATE=true; the request then goes
                        to the checked address (``pinned``), so DNS cannot swap it after the
                        check
    Deliverer           claims due deliveries under a lease (like jobs), POSTs them signed
                        per Standard Webhooks, logs every attempt, retries with capped
                        exponential backoff; a deliverer that dies mid-way loses its lease
                        and another one delivers: at least once
    DeliveryThread      a Deliverer's loop in a thread, run next to the job workers

The body is ``{"type", "timestamp", "data": {"model": ..., "job": ...}}``; the headers are
``webhook-id`` (the delivery id, the same on every retry so receivers can deduplicate),
``webhook-timestamp`` and ``webhook-signature`` (``v1,`` + base64 HMAC-SHA256 over
``id.timestamp.body`` with the endpoint's secret), made by the ``standardwebhooks`` package.
"""

from __future__ import annotations

import base64
import ipaddress
import json
import logging
import secrets
import socket
import threading
import time
import uuid
from dataclasses import dataclass
from datetime import timedelta
from typing import Any
from urllib.parse import urlsplit

import httpx
from sqlalchemy import and_, insert, or_, select, update
from sqlalchemy.orm import Session, sessionmaker
from standardwebhooks.webhooks import Webhook as Signer

from app.db.models import Job, Model, Webhook, WebhookAttempt, WebhookDelivery, utcnow
from app.metrics import WEBHOOK_ATTEMPTS

__all__ = [
    "EVENT_TYPES",
    "DeliveryThread",
    "Deliverer",
    "TargetRefused",
    "check_target",
    "new_secret",
    "pinned",
    "record_model_event",
    "start_delivery_thread",
    "valid_secret",
]

log = logging.getLogger("shapesearch.webhooks")

EVENT_TYPES = ("model.ready", "model.failed", "model.deleted")


class TargetRefused(ValueError):
    """A webhook URL the service will not call."""


# --- the outbox -----------------------------------------------------------------------


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
            }
            for hook_id in endpoints
        ],
    )
    return len(endpoints)


# --- endpoints ------------------------------------------------------------------------


def new_secret() -> str:
    """A Standard Webhooks secret: ``whsec_`` + base64 of 24 random bytes."""
    return "whsec_" + base64.b64encode(secrets.token_bytes(24)).decode()


def valid_secret(secret: str) -> bool:
    """True if ``secret`` is ``whsec_``-prefixed (or bare) base64 of at least 16 bytes."""
    try:
        raw = base64.b64decode(secret.removeprefix("whsec_") + "==", validate=False)
    except ValueError:
        return False
    return len(raw) >= 16


def check_target(url: str, *, allow_private: bool) -> str | None:
    """Refuse URLs the service must not call: not http(s), no host, credentials, or (unless
    ``allow_private``) a host that resolves to a non-public address.

    Returns the checked address to connect to (None with ``allow_private``), so that the
    request cannot be sent to another address by a second, different DNS answer.
    """
    parts = urlsplit(url)
    if parts.scheme not in ("http", "https"):
        raise TargetRefused("the URL must be http:// or https://")
    if not parts.hostname:
        raise TargetRefused("the URL has no host")
    if parts.username or parts.password:
        raise TargetRefused("the URL must not carry credentials")
    if allow_private:
        return None
    try:
        port = parts.port or (443 if parts.scheme == "https" else 80)
        infos = socket.getaddrinfo(parts.hostname, port, proto=socket.IPPROTO_TCP)
    except (OSError, ValueError) as error:
        raise TargetRefused(f"the host {parts.hostname!r} cannot be resolved: {error}") from None
    addresses = [ipaddress.ip_address(info[4][0]) for info in infos]
    for address in addresses:
        if not address.is_global:
            raise TargetRefused(
                f"the host {parts.hostname!r} resolves to the non-public address {address}; "
                "set SHAPESEARCH_WEBHOOK_ALLOW_PRIVATE=true to allow private targets"
            )
    if not addresses:
        raise TargetRefused(f"the host {parts.hostname!r} has no address")
    return str(addresses[0])


def pinned(url: str, address: str | None) -> tuple[str, dict[str, str], dict[str, Any]]:
    """The URL aimed at ``address`` with the Host header and TLS server name of the original
    host (certificates are still verified against that name). None: the URL unchanged."""
    if address is None:
        return url, {}, {}
    parts = urlsplit(url)
    host = parts.hostname or ""
    literal = f"[{address}]" if ":" in address else address
    netloc = literal if parts.port is None else f"{literal}:{parts.port}"
    host_header = host if parts.port is None else f"{host}:{parts.port}"
    extensions = {"sni_hostname": host} if parts.scheme == "https" else {}
    return parts._replace(netloc=netloc).geturl(), {"host": host_header}, extensions


# --- delivering -----------------------------------------------------------------------


def capped_backoff(attempts: int, base: float, cap: float) -> float:
    """Delay after failed attempt number ``attempts``: base, 2*base, 4*base, ... <= cap."""
    return min(cap, base * 2 ** max(0, attempts - 1))


@dataclass(frozen=True)
class _Claimed:
    id: uuid.UUID
    attempts: int
    url: str
    secret: str
    payload: dict[str, Any]


@dataclass(frozen=True)
class _Outcome:
    status_code: int | None
    error: str | None
    duration_ms: float

    @property
    def ok(self) -> bool:
        return self.status_code is not None and 200 <= self.status_code < 300


class Deliverer:
    """Claims and sends due deliveries; every database step is one short transaction."""

    def __init__(
        self,
        sessions: sessionmaker[Session],
        *,
        worker_id: str,
        allow_private: bool,
        timeout: float,
        max_attempts: int,
        backoff_base: float,
        backoff_cap: float,
        lease_seconds: float,
    ) -> None:
        self.sessions = sessions
        self.worker_id = worker_id
        self.allow_private = allow_private
        self.max_attempts = max_attempts
        self.backoff_base = backoff_base
        self.backoff_cap = backoff_cap
        self.lease = timedelta(seconds=max(lease_seconds, timeout * 2))
        # Redirects are never followed: a 3xx is a failed attempt.
        self.client = httpx.Client(timeout=timeout, follow_redirects=False, trust_env=False)

    def close(self) -> None:
        self.client.close()

    def claim(self) -> _Claimed | None:
        """Take the next due delivery, or one whose deliverer's lease expired."""
        now = utcnow()
        due = (
            select(WebhookDelivery.id)
            .where(
                or_(
                    and_(WebhookDelivery.status == "pending", WebhookDelivery.run_after <= now),
                    and_(
                        WebhookDelivery.status == "sending", WebhookDelivery.leased_until < now
                    ),
                )
            )
            .order_by(WebhookDelivery.run_after)
            .limit(1)
            .with_for_update(skip_locked=True)
            .scalar_subquery()
        )
        with self.sessions.begin() as session:
            row = session.execute(
                update(WebhookDelivery)
                .where(WebhookDelivery.id == due)
                .values(
                    status="sending",
                    worker_id=self.worker_id,
                    attempts=WebhookDelivery.attempts + 1,
                    leased_until=now + self.lease,
                    updated_at=now,
                )
                .returning(
                    WebhookDelivery.id,
                    WebhookDelivery.attempts,
                    WebhookDelivery.webhook_id,
                    WebhookDelivery.payload,
                )
            ).one_or_none()
            if row is None:
                return None
            hook = session.get(Webhook, row.webhook_id)
            if hook is None:  # deleted meanwhile; its deliveries went with it
                return None
            return _Claimed(row.id, row.attempts, hook.url, hook.secret, row.payload)

    def send(self, claimed: _Claimed) -> _Outcome:
        started = time.perf_counter()
        try:
            address = check_target(claimed.url, allow_private=self.allow_private)
            url, host_header, extensions = pinned(claimed.url, address)
            body = json.dumps(claimed.payload, separators=(",", ":"))
            now = utcnow()
            headers = {
                "content-type": "application/json",
                "user-agent": "shapesearch-webhooks/1",
                "webhook-id": str(claimed.id),
                "webhook-timestamp": str(int(now.timestamp())),
                "webhook-signature": Signer(claimed.secret).sign(str(claimed.id), now, body),
                **host_header,
            }
            response = self.client.post(
                url, content=body.encode(), headers=headers, extensions=extensions
            )
        except (httpx.HTTPError, TargetRefused, OSError) as error:
            elapsed = (time.perf_counter() - started) * 1000
            return _Outcome(None, f"{type(error).__name__}: {error}"[:2000], elapsed)
        elapsed = (time.perf_counter() - started) * 1000
        error = None if 200 <= response.status_code < 300 else f"HTTP {response.status_code}"
        return _Outcome(response.status_code, error, elapsed)

    def finish(self, claimed: _Claimed, outcome: _Outcome) -> bool:
        """Log the attempt and settle the delivery; False if the lease was lost meanwhile."""
        now = utcnow()
        if outcome.ok:
            values: dict[str, Any] = {"status": "delivered"}
        elif claimed.attempts >= self.max_attempts:
            values = {"status": "failed"}
        else:
            delay = capped_backoff(claimed.attempts, self.backoff_base, self.backoff_cap)
            values = {"status": "pending", "run_after": now + timedelta(seconds=delay)}
        with self.sessions.begin() as session:
            settled = session.execute(
                update(WebhookDelivery)
                .where(
                    WebhookDelivery.id == claimed.id,
                    WebhookDelivery.status == "sending",
                    WebhookDelivery.worker_id == self.worker_id,
                    WebhookDelivery.attempts == claimed.attempts,
                )
                .values(leased_until=None, worker_id=None, updated_at=now, **values)
            )
            if settled.rowcount != 1:
                return False
            session.add(
                WebhookAttempt(
                    delivery_id=claimed.id,
                    attempt=claimed.attempts,
                    status_code=outcome.status_code,
                    error=outcome.error,
                    duration_ms=outcome.duration_ms,
                    created_at=now,
                )
            )
        WEBHOOK_ATTEMPTS.labels(outcome=_OUTCOMES[values["status"]]).inc()
        return True

    def run_once(self) -> bool:
        """Deliver one due event; False if there was none."""
        claimed = self.claim()
        if claimed is None:
            return False
        outcome = self.send(claimed)
        if not self.finish(claimed, outcome):
            log.warning("delivery %s: lease lost, attempt not recorded", claimed.id)
        elif not outcome.ok:
            log.info("delivery %s attempt %d: %s", claimed.id, claimed.attempts, outcome.error)
        return True


# Metric label of each settled state of a delivery.
_OUTCOMES = {"delivered": "delivered", "pending": "retry", "failed": "failed"}


class DeliveryThread:
    """Runs a ``Deliverer`` until stopped; a database outage is waited out."""

    def __init__(self, deliverer: Deliverer, poll_interval: float) -> None:
        self.deliverer = deliverer
        self.poll_interval = poll_interval
        self.stop_event = threading.Event()
        self.thread = threading.Thread(target=self._run, name="webhooks", daemon=True)

    def start(self) -> None:
        self.thread.start()

    def stop(self) -> None:
        self.stop_event.set()
        self.thread.join()
        self.deliverer.close()

    def _run(self) -> None:
        while not self.stop_event.is_set():
            try:
                found = self.deliverer.run_once()
            except Exception:
                log.exception("webhook delivery failed; retrying")
                found = False
            if not found:
                self.stop_event.wait(self.poll_interval)


def start_delivery_thread(settings: Any, sessions: sessionmaker[Session]) -> DeliveryThread:
    """A started ``DeliveryThread`` configured from the service ``settings``."""
    deliverer = Deliverer(
        sessions,
        worker_id=f"{socket.gethostname()}:webhooks:{secrets.token_hex(3)}",
        allow_private=settings.webhook_allow_private,
        timeout=settings.webhook_timeout_seconds,
        max_attempts=settings.webhook_max_attempts,
        backoff_base=settings.webhook_backoff_seconds,
        backoff_cap=settings.webhook_backoff_max_seconds,
        lease_seconds=settings.lease_seconds,
    )
    thread = DeliveryThread(deliverer, settings.poll_interval)
    thread.start()
    return thread
