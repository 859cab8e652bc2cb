"""Delivering webhooks: a ``Deliverer`` claims due deliveries under a lease (like jobs,
``app.jobs.lease``), POSTs them signed per Standard Webhooks, logs every attempt and retries
with capped exponential backoff; a deliverer that dies mid-way loses its lease and another
one delivers: at least once. ``DeliveryLanes`` runs one in a few threads next to the job
workers.

An endpoint has one delivery in flight at a time: a claim passes over endpoints with a
delivery being sent under a live lease. So an endpoint receives its events one after
another, in order unless one is retried, and an endpoint that hangs holds one lane for its
timeout while the other lanes serve every other endpoint. With one lane, an endpoint hanging
with a backlog made each other endpoint's event wait out one timeout
(``bench/webhook_fairness.py``). Claims go one at a time, across processes too
(``app.db.session.one_at_a_time``: an advisory lock on PostgreSQL, the write lock on SQLite),
so each reads the one before it committed and the rule is exact; on SQLite a claim that read
and then wrote also failed ("database is locked") whenever another connection committed in
between. A look that finds nothing takes no lock.
"""

from __future__ import annotations

import json
import logging
import secrets
import socket
import threading
import time
import uuid
from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Any

import httpx
from sqlalchemy import (
    BindParameter,
    ColumnElement,
    Select,
    bindparam,
    exists,
    select,
    update,
)
from sqlalchemy.orm import Session, aliased, sessionmaker
from standardwebhooks.webhooks import Webhook as Signer

from app.db.doorbells import WEBHOOKS, Doorbell
from app.db.models import Webhook, WebhookAttempt, WebhookDelivery, utcnow
from app.db.session import one_at_a_time, rows_changed
from app.jobs.lease import backoff_seconds, claim_next
from app.observability.logs import Outage
from app.observability.metrics import WEBHOOK_ATTEMPTS
from app.webhooks.targets import TargetRefused, check_target, pinned

__all__ = ["CLAIMS", "Deliverer", "DeliveryLanes", "start_delivery_lanes"]

log = logging.getLogger("shapesearch.webhooks")

# The lock that claims (and requeues) take one at a time (``one_at_a_time``).
CLAIMS = "shapesearch.webhook-claims"


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
        # Redirects are never followed: a 3xx is a failed attempt. The client is shared by
        # the lanes (httpx clients are thread-safe).
        self.client = httpx.Client(timeout=timeout, follow_redirects=False, trust_env=False)
        # Lanes claim one at a time: a claim must see the one before it committed, or two
        # lanes could take two deliveries of one endpoint.
        self._claiming = threading.Lock()

    def close(self) -> None:
        self.client.close()

    def claim(self) -> _Claimed | None:
        """Take the next due delivery in turn order (endpoints take turns), or one whose
        deliverer's lease expired, of an endpoint with no other delivery in flight."""
        now = utcnow()
        with self._claiming:
            # A look that finds nothing (an idle lane's) takes no lock.
            with self.sessions() as session:
                if not _claimable(session, now):
                    return None
            return self._claim(now)

    def _claim(self, now: datetime) -> _Claimed | None:
        with self.sessions.begin() as session:
            # Claims of every process one after another: each reads the one before it
            # committed (so an endpoint's one delivery in flight is the rule across
            # processes too), and on SQLite the claim's write cannot fail for a commit
            # made between its read and its write.
            one_at_a_time(session, CLAIMS)
            claimable = _claimable(session, now)
            if not claimable:
                return None
            row = claim_next(
                session, WebhookDelivery, waiting="pending", held="sending",
                worker_id=self.worker_id, now=now, lease=self.lease, among=claimable,
                returning=(WebhookDelivery.id, WebhookDelivery.attempts,
                           WebhookDelivery.webhook_id, WebhookDelivery.payload),
            )
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
        failure = None if 200 <= response.status_code < 300 else f"HTTP {response.status_code}"
        return _Outcome(response.status_code, failure, elapsed)

    def finish(self, claimed: _Claimed, outcome: _Outcome) -> bool:
        """Log the attempt and settle the delivery; False if the lease was lost meanwhile."""
        now = utcnow()
        if outcome.ok:
            values: dict[str, Any] = {"status": "delivered"}
        elif claimed.attempts >= self.max_attempts:
            values = {"status": "failed"}
        else:
            delay = backoff_seconds(claimed.attempts, self.backoff_base, self.backoff_cap)
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
            if rows_changed(settled) != 1:
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

    def deliver(self, claimed: _Claimed) -> None:
        """Send a claimed delivery and settle it."""
        outcome = self.send(claimed)
        if not self.finish(claimed, outcome):
            log.warning("delivery %s: lease lost, attempt not recorded", claimed.id)
        elif not outcome.ok:
            log.info("delivery %s attempt %d: %s", claimed.id, claimed.attempts, outcome.error)


def _claimable_queries() -> tuple[Select[Any], Select[Any]]:
    """The two reads of ``_claimable``, built once (building them anew cost more than
    running them) with the time as the parameter ``now``."""
    now: BindParameter[datetime] = bindparam("now")
    candidate = aliased(WebhookDelivery, name="candidate")
    in_flight = aliased(WebhookDelivery, name="in_flight")

    def no_other_in_flight(endpoint: Any) -> ColumnElement[bool]:
        busy = exists().where(
            in_flight.webhook_id == endpoint,
            in_flight.status == "sending",
            in_flight.leased_until >= now,
        )
        return ~busy.correlate_except(in_flight)

    lapsed = select(candidate.id).where(
        candidate.status == "sending",
        candidate.leased_until < now,
        no_other_in_flight(candidate.webhook_id),
    )
    # Ordered by turn alone, so that the endpoint's index serves the order too (turns
    # of one endpoint differ but for the rare tie of two replicas queueing at once).
    next_due = (
        select(candidate.id)
        .where(
            candidate.webhook_id == Webhook.id,
            candidate.status == "pending",
            candidate.run_after <= now,
        )
        .order_by(candidate.turn)
        .limit(1)
        .correlate(Webhook)
        .scalar_subquery()
    )
    heads = select(next_due).select_from(Webhook).where(no_other_in_flight(Webhook.id))
    return lapsed, heads


_LAPSED, _NEXT_OF_IDLE_ENDPOINTS = _claimable_queries()


def _claimable(session: Session, now: datetime) -> list[uuid.UUID]:
    """The deliveries a claim may take: each endpoint's next due delivery, for endpoints
    with no delivery being sent under a live lease, and deliveries whose deliverer's lease
    ran out (it died mid-way), of endpoints with none other in flight.

    Read per endpoint (an index seek each on ``ix_webhook_deliveries_endpoint_turn``), not
    per due delivery: a look that passed over every due delivery of the endpoints in flight
    cost in proportion to their backlog (18-25 ms past 10,000 on SQLite, where an empty
    outbox costs 4 ms), and every idle lane looks at every ring. The ids come back as a list
    so that the claim looks them up by primary key (``claim_next(among=...)``; with the
    subquery in its place SQLite walked the claim index in turn order and tested each row).
    """
    found = [
        *session.scalars(_LAPSED, {"now": now}),
        *session.scalars(_NEXT_OF_IDLE_ENDPOINTS, {"now": now}),
    ]
    return [delivery for delivery in found if delivery is not None]


# Metric label of each settled state of a delivery.
_OUTCOMES = {"delivered": "delivered", "pending": "retry", "failed": "failed"}


class DeliveryLanes:
    """Runs a ``Deliverer`` in ``lanes`` threads until stopped; a database outage is waited
    out.

    An idle lane waits until ``doorbell`` rings (a delivery was queued), which wakes every
    idle lane, or for ``poll_interval`` seconds (a retry falls due without a ring); on a
    timeout it looks only if no lane of the process has looked for that long, so idle lanes
    poll the database as often as one (four lanes polled four times as often). A lane that
    claims rings again, as the job workers do: one ring may announce many deliveries, and a
    peer's clear may have taken it from a lane whose look had just missed them.
    """

    def __init__(
        self,
        deliverer: Deliverer,
        *,
        lanes: int,
        poll_interval: float,
        doorbell: Doorbell = WEBHOOKS,
    ) -> None:
        self.deliverer = deliverer
        self.poll_interval = poll_interval
        self.doorbell = doorbell
        self.stop_event = threading.Event()
        self._last_look = time.monotonic()
        self.threads = [
            threading.Thread(target=self._run, name=f"webhooks-{lane}", daemon=True)
            for lane in range(lanes)
        ]

    def start(self) -> None:
        for thread in self.threads:
            thread.start()

    def stop(self) -> None:
        """Stop claiming; wait for the deliveries being sent (each within its timeout)."""
        self.stop_event.set()
        self.doorbell.ring()  # idle lanes see the stop now
        for thread in self.threads:
            thread.join()
        self.deliverer.close()

    def _run(self) -> None:
        outage = Outage(log, "webhook deliveries: the database")
        while not self.stop_event.is_set():
            self.doorbell.clear()  # before the look: a ring during it is kept
            if self._look(outage):
                continue
            while not self.stop_event.is_set():
                if self.doorbell.wait(self.poll_interval):
                    break
                if time.monotonic() - self._last_look >= self.poll_interval:
                    break  # nobody looked for a whole interval: this lane does

    def _look(self, outage: Outage) -> bool:
        """Deliver one due event; False if there was none (or the database is away)."""
        self._last_look = time.monotonic()
        try:
            claimed = self.deliverer.claim()
            outage.end()
            if claimed is None:
                return False
            self.doorbell.ring()  # more may be due: an idle peer looks too
            self.deliverer.deliver(claimed)
        except Exception as error:
            outage.report(error)
            return False
        return True


def start_delivery_lanes(settings: Any, sessions: sessionmaker[Session]) -> DeliveryLanes:
    """Started ``DeliveryLanes`` configured from the service ``settings``."""
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
    lanes = DeliveryLanes(
        deliverer, lanes=settings.webhook_lanes, poll_interval=settings.poll_interval
    )
    lanes.start()
    return lanes
