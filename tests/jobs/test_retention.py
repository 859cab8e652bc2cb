"""History retention (``app.db.retention``) on both databases: settled jobs and webhook
deliveries older than the setting go, with their attempts, and so do old change-feed events;
a model's newest job, a tenant's newest event, anything unsettled and anything young stay."""

from __future__ import annotations

import threading
import time
import uuid
from datetime import datetime, timedelta

import pytest
from fastapi.testclient import TestClient
from prometheus_client import REGISTRY
from sqlalchemy import func, select, update
from sqlalchemy.orm import Session, sessionmaker

from app.api.main import create_app
from app.db.feed import record_event
from app.db.models import (
    DuplicateReport,
    FeedState,
    IndexEvent,
    Job,
    Model,
    Webhook,
    WebhookAttempt,
    WebhookDelivery,
    utcnow,
)
from app.db.retention import HistoryPruner, prune_history
from app.search.duplicate_reports import is_stale
from tests.conftest import fake_describe, make_settings

NOW = utcnow()
OLD = NOW - timedelta(days=40)
YOUNG = NOW - timedelta(days=5)


def add_model(session: Session, tenant: str = "t") -> uuid.UUID:
    model = Model(tenant=tenant, meta={}, status="ready", file_name="a.stl", file_size=1,
                  file_sha256="0" * 64, file_format="stl")
    session.add(model)
    session.flush()
    return model.id


def add_job(
    session: Session, model_id: uuid.UUID | None, status: str, at: datetime,
    kind: str = "redescribe", tenant: str = "t",
) -> uuid.UUID:
    job = Job(model_id=model_id, tenant=tenant, kind=kind, status=status, created_at=at,
              updated_at=at, run_after=at)
    session.add(job)
    session.flush()
    return job.id


def add_delivery(
    session: Session, webhook_id: uuid.UUID, status: str, at: datetime, attempts: int = 2
) -> uuid.UUID:
    delivery = WebhookDelivery(webhook_id=webhook_id, event_type="model.ready", payload={},
                               status=status, attempts=attempts, created_at=at,
                               updated_at=at, run_after=at)
    session.add(delivery)
    session.flush()
    session.add_all(WebhookAttempt(delivery_id=delivery.id, attempt=number, status_code=500,
                                   duration_ms=1.0, created_at=at)
                    for number in range(1, attempts + 1))
    return delivery.id


def pruned_total(table: str) -> float:
    labels = {"table": table}
    return REGISTRY.get_sample_value("shapesearch_history_pruned_total", labels) or 0.0


def job_ids(sessions: sessionmaker[Session]) -> set[uuid.UUID]:
    with sessions() as session:
        return set(session.scalars(select(Job.id)))


@pytest.mark.slow
def test_settled_jobs_go_after_the_retention_but_a_models_newest_job_stays(
    sessions: sessionmaker[Session],
) -> None:
    with sessions.begin() as session:
        model = add_model(session)
        old_done = add_job(session, model, "done", OLD - timedelta(days=2), kind="describe")
        old_failed = add_job(session, model, "failed", OLD - timedelta(days=1))
        newest_but_old = add_job(session, model, "done", OLD)
        lonely = add_model(session)
        only_job = add_job(session, lonely, "failed", OLD)  # tells why the model failed
        waiting = add_model(session)
        stale_queued = add_job(session, waiting, "queued", OLD - timedelta(days=1))
        running = add_job(session, waiting, "running", OLD)  # its newest: a lease held long
        young = add_model(session)
        young_done = add_job(session, young, "done", YOUNG - timedelta(days=1))
        add_job(session, young, "done", YOUNG)
        report_job = add_job(session, None, "done", OLD, kind="duplicates")

    counted = pruned_total("jobs")
    pruned = prune_history(sessions, days=30, now=NOW)

    gone = {old_done, old_failed, report_job}
    assert pruned.jobs == len(gone)
    assert pruned_total("jobs") - counted == len(gone)
    remaining = job_ids(sessions)
    assert not gone & remaining
    assert {newest_but_old, only_job, stale_queued, running, young_done} <= remaining
    assert len(remaining) == 6


def test_settled_deliveries_go_with_their_attempts_and_pending_ones_stay(
    sessions: sessionmaker[Session],
) -> None:
    with sessions.begin() as session:
        webhook = Webhook(tenant="t", url="https://example.com/h", events=["model.ready"],
                          secret="whsec_" + "A" * 32)
        session.add(webhook)
        session.flush()
        delivered = add_delivery(session, webhook.id, "delivered", OLD)
        failed = add_delivery(session, webhook.id, "failed", OLD, attempts=5)
        pending = add_delivery(session, webhook.id, "pending", OLD)  # an endpoint away long
        young = add_delivery(session, webhook.id, "delivered", YOUNG)

    pruned = prune_history(sessions, days=30, now=NOW)

    assert pruned.webhook_deliveries == 2
    with sessions() as session:
        assert set(session.scalars(select(WebhookDelivery.id))) == {pending, young}
        attempts_of = dict(session.execute(
            select(WebhookAttempt.delivery_id, func.count()).group_by(WebhookAttempt.delivery_id)
        ).all())
    assert attempts_of == {pending: 2, young: 2}
    assert delivered not in attempts_of and failed not in attempts_of


@pytest.mark.slow
def test_zero_days_keeps_everything_and_batches_reach_every_row(
    sessions: sessionmaker[Session],
) -> None:
    with sessions.begin() as session:
        model = add_model(session)
        for day in range(7):  # six old ones and the model's newest
            add_job(session, model, "done", OLD - timedelta(days=day))

    assert prune_history(sessions, days=0, now=NOW).jobs == 0
    assert len(job_ids(sessions)) == 7
    assert prune_history(sessions, days=30, batch=4, now=NOW).jobs == 6  # 4, then 2
    assert len(job_ids(sessions)) == 1


def test_the_pruner_runs_at_start_and_stops_at_once(sessions: sessionmaker[Session]) -> None:
    with sessions.begin() as session:
        model = add_model(session)
        add_job(session, model, "done", OLD)
        add_job(session, model, "done", NOW)
    pruner = HistoryPruner(sessions, days=30, interval=3600).start()
    deadline = time.monotonic() + 10
    while len(job_ids(sessions)) > 1 and time.monotonic() < deadline:
        time.sleep(0.05)
    started = time.monotonic()
    pruner.stop()  # waits out neither the hour nor a pass
    assert time.monotonic() - started < 2
    assert len(job_ids(sessions)) == 1
    assert not pruner.thread.is_alive()


@pytest.mark.slow
def test_serve_prunes_at_start_a_pruned_job_is_not_found_and_its_model_shows_its_newest(
    database_url: str, sessions: sessionmaker[Session],
) -> None:
    with sessions.begin() as session:
        model = add_model(session, tenant="default")
        old = add_job(session, model, "done", OLD, tenant="default")
        newest = add_job(session, model, "done", OLD + timedelta(days=1), tenant="default")
    settings = make_settings(database_url, worker_count=1, history_days=30)
    app = create_app(settings, embedded_worker=True, job_handler=fake_describe)
    with TestClient(app) as client:
        deadline = time.monotonic() + 10
        while client.get(f"/v1/jobs/{old}").status_code == 200 and time.monotonic() < deadline:
            time.sleep(0.05)
        missing = client.get(f"/v1/jobs/{old}")
        assert missing.status_code == 404
        assert missing.json()["type"] == "urn:shapesearch:problem:job-not-found"
        assert client.get(f"/v1/models/{model}").json()["job"]["id"] == str(newest)


def test_a_stopped_pass_deletes_nothing(sessions: sessionmaker[Session]) -> None:
    with sessions.begin() as session:
        model = add_model(session)
        add_job(session, model, "done", OLD)
        add_job(session, model, "done", NOW)
    stop = threading.Event()
    stop.set()
    assert prune_history(sessions, 30, stop=stop).jobs == 0
    assert len(job_ids(sessions)) == 2


def add_events(sessions: sessionmaker[Session], *made: tuple[str | None, datetime]) -> None:
    """One change-feed event per (tenant, when), revisions 1, 2, ... in order."""
    with sessions.begin() as session:
        for index_id, (tenant, at) in enumerate(made, start=1):
            revision = record_event(session, index_id, "ready", tenant or "none")
            session.execute(update(IndexEvent).where(IndexEvent.revision == revision)
                            .values(tenant=tenant, created_at=at))


def test_old_feed_events_go_but_each_tenants_newest_stays_and_the_gap_is_recorded(
    sessions: sessionmaker[Session],
) -> None:
    add_events(
        sessions,
        ("a", OLD - timedelta(days=3)),  # 1: a has a newer one
        ("b", OLD - timedelta(days=2)),  # 2: b has a newer one
        ("a", OLD - timedelta(days=1)),  # 3: a's newest
        ("c", OLD),  # 4: c's newest
        (None, OLD),  # 5: from before events named their tenant
        ("b", YOUNG),  # 6
    )
    counted = pruned_total("index_events")

    pruned = prune_history(sessions, days=30, now=NOW)

    assert pruned.index_events == 3
    assert pruned_total("index_events") - counted == 3
    with sessions() as session:
        assert set(session.scalars(select(IndexEvent.revision))) == {3, 4, 6}
        assert session.scalar(select(FeedState.pruned_through)) == 5
        # A tenant's reports are dated as before: a's newest event is still 3.
        assert is_stale(session, DuplicateReport(tenant="a", revision=2))
        assert not is_stale(session, DuplicateReport(tenant="a", revision=3))
        assert not is_stale(session, DuplicateReport(tenant="c", revision=4))
    assert prune_history(sessions, days=30, now=NOW).index_events == 0


def test_feed_batches_reach_every_old_event_and_stop_at_young_ones(
    sessions: sessionmaker[Session],
) -> None:
    add_events(sessions, *[("a", OLD - timedelta(hours=9 - hour)) for hour in range(9)],
               ("a", YOUNG), ("a", YOUNG))

    assert prune_history(sessions, days=30, batch=4, now=NOW).index_events == 9  # 4, 4, 1
    with sessions() as session:
        assert set(session.scalars(select(IndexEvent.revision))) == {10, 11}
        assert session.scalar(select(FeedState.pruned_through)) == 9
