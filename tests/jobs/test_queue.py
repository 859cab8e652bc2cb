"""The job queue on both backends: exactly-once claiming under concurrency, leases,
take-over of expired leases, retries with backoff, release on shutdown."""

from __future__ import annotations

import threading
import uuid
from collections import Counter
from datetime import timedelta

import pytest
from alembic import command
from sqlalchemy import (
    Column,
    Engine,
    Integer,
    MetaData,
    String,
    Table,
    Uuid,
    inspect,
    select,
    update,
)
from sqlalchemy.orm import Session, sessionmaker

from app.db.migrate import alembic_config, upgrade
from app.db.models import Job, Model, Upload, UTCDateTime, utcnow
from app.db.session import make_engine, make_session_factory
from app.ingest.redescribe import enqueue_models
from app.jobs.lease import backoff_seconds
from app.jobs.queue import Claim, JobQueue
from app.jobs.turns import queue_job

RESULT = {
    "n_points": 10,
    "cutoff": {"mode": "fixed", "n": 3, "solver_calls": 1, "params": {}, "predicted": []},
    "eigenvalues": [0.0, 1.0, 2.0],
    "descriptor": b"\x00" * 16,
    "descriptor_version": "test",
    "timings": {},
}


@pytest.fixture
def engine(database_url: str) -> Engine:
    engine = make_engine(database_url)
    upgrade(engine)
    yield engine
    engine.dispose()


@pytest.fixture
def sessions(engine: Engine) -> sessionmaker[Session]:
    return make_session_factory(engine)


def make_queue(sessions: sessionmaker[Session], **options: float) -> JobQueue:
    values = {"lease_seconds": 30.0, "max_attempts": 3, "backoff_base": 10.0, "backoff_cap": 60.0}
    values.update(options)
    return JobQueue(sessions, **values)  # type: ignore[arg-type]


def add_jobs(sessions: sessionmaker[Session], count: int, tenant: str = "t") -> list[uuid.UUID]:
    """``count`` queued models of ``tenant`` with their jobs; returns the job ids."""
    job_ids = []
    with sessions.begin() as session:
        for i in range(count):
            model = Model(
                id=uuid.uuid4(),
                tenant=tenant,
                meta={},
                status="queued",
                file_name=f"{i}.xyz",
                file_size=1,
                file_sha256="0" * 64,
                file_format="xyz",
            )
            session.add(model)
            session.flush()
            session.add(Upload(model_id=model.id, content=b"1 2 3\n"))
            job_ids.append(queue_job(session, tenant=tenant, model_id=model.id).id)
    return job_ids


def job_row(sessions: sessionmaker[Session], job_id: uuid.UUID) -> Job:
    with sessions() as session:
        job = session.get(Job, job_id)
        assert job is not None
        return job


def model_status(sessions: sessionmaker[Session], claim: Claim) -> str:
    with sessions() as session:
        return str(session.scalar(select(Model.status).where(Model.id == claim.model_id)))


def test_backoff_doubles_and_is_capped() -> None:
    assert [backoff_seconds(a, 5, 60) for a in range(1, 7)] == [5, 10, 20, 40, 60, 60]


@pytest.mark.slow
def test_concurrent_workers_take_each_job_exactly_once(database_url: str) -> None:
    """Four workers, each with its own engine (as separate processes would have), race for
    200 jobs with an instant handler: every job is done exactly once."""
    setup = make_engine(database_url)
    upgrade(setup)
    job_ids = add_jobs(make_session_factory(setup), 200)
    done: list[uuid.UUID] = []
    lock = threading.Lock()
    errors: list[BaseException] = []

    def work(index: int) -> None:
        engine = make_engine(database_url)
        queue = make_queue(make_session_factory(engine))
        try:
            while (claim := queue.claim(f"w{index}")) is not None:
                with lock:
                    done.append(claim.job_id)
                assert queue.complete(claim, RESULT)
        except BaseException as error:  # surfaced by the assertion below
            errors.append(error)
        finally:
            engine.dispose()

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    assert not errors, errors
    counts = Counter(done)
    assert set(counts) == set(job_ids)
    assert max(counts.values()) == 1
    with make_session_factory(setup)() as session:
        statuses = Counter(session.scalars(select(Job.status)))
        ready = Counter(session.scalars(select(Model.status)))
    assert statuses == {"done": 200} and ready == {"ready": 200}
    setup.dispose()


def test_an_expired_lease_is_taken_over_and_the_old_claim_loses(
    sessions: sessionmaker[Session],
) -> None:
    (job_id,) = add_jobs(sessions, 1)
    queue = make_queue(sessions)
    first = queue.claim("first")
    assert first is not None and first.attempts == 1
    assert queue.claim("second") is None  # leased: nobody else gets it
    assert model_status(sessions, first) == "processing"

    with sessions.begin() as session:  # the first worker died: its lease lapses
        session.execute(
            update(Job).where(Job.id == job_id).values(leased_until=utcnow() - timedelta(1))
        )
    second = queue.claim("second")
    assert second is not None and second.job_id == job_id and second.attempts == 2

    assert not queue.renew(first)
    assert not queue.complete(first, RESULT)  # a lost lease must not overwrite
    assert not queue.fail(first, {"type": "x", "title": "x", "detail": "x"})
    assert job_row(sessions, job_id).status == "running"
    assert queue.renew(second)
    assert queue.complete(second, RESULT)
    job = job_row(sessions, job_id)
    assert job.status == "done" and job.worker_id == "second"
    assert model_status(sessions, second) == "ready"


def test_renewing_extends_the_lease(sessions: sessionmaker[Session]) -> None:
    (job_id,) = add_jobs(sessions, 1)
    queue = make_queue(sessions, lease_seconds=5)
    claim = queue.claim("w")
    assert claim is not None
    before = job_row(sessions, job_id).leased_until
    queue.lease = timedelta(seconds=500)
    assert queue.renew(claim)
    after = job_row(sessions, job_id).leased_until
    assert before is not None and after is not None and after - before > timedelta(seconds=400)


def test_transient_errors_retry_with_backoff_until_attempts_run_out(
    sessions: sessionmaker[Session],
) -> None:
    (job_id,) = add_jobs(sessions, 1)
    queue = make_queue(sessions, max_attempts=2, backoff_base=10.0)
    error = {"type": "urn:x", "title": "Solver error", "detail": "no convergence"}
    claim = queue.claim("w")
    assert claim is not None
    assert queue.retry(claim, error)
    job = job_row(sessions, job_id)
    assert job.status == "queued" and job.last_error == error and job.attempts == 1
    assert job.run_after > utcnow() + timedelta(seconds=8)  # backed off
    assert model_status(sessions, claim) == "queued"
    assert queue.claim("w") is None  # not due yet

    with sessions.begin() as session:
        session.execute(update(Job).where(Job.id == job_id).values(run_after=utcnow()))
    again = queue.claim("w")
    assert again is not None and again.attempts == 2
    assert queue.retry(again, error)  # attempts spent: failed for good
    job = job_row(sessions, job_id)
    assert job.status == "failed" and job.last_error == error
    assert model_status(sessions, again) == "failed"
    assert queue.claim("w") is None


def test_release_hands_the_job_back_without_counting_it(sessions: sessionmaker[Session]) -> None:
    (job_id,) = add_jobs(sessions, 1)
    queue = make_queue(sessions)
    claim = queue.claim("w")
    assert claim is not None
    assert queue.release(claim)
    job = job_row(sessions, job_id)
    assert job.status == "queued" and job.attempts == 0 and job.worker_id is None
    assert not queue.complete(claim, RESULT)
    other = queue.claim("other")
    assert other is not None and other.attempts == 1


def test_a_deleted_model_ends_its_claim(sessions: sessionmaker[Session]) -> None:
    add_jobs(sessions, 1)
    queue = make_queue(sessions)
    claim = queue.claim("w")
    assert claim is not None
    with sessions.begin() as session:
        session.execute(Model.__table__.delete().where(Model.id == claim.model_id))
    assert queue.upload_of(claim) is None
    assert not queue.renew(claim)
    assert not queue.complete(claim, RESULT)


def _lapse(sessions: sessionmaker[Session], job_id: uuid.UUID) -> None:
    """The worker holding ``job_id`` died: its lease lapses."""
    with sessions.begin() as session:
        session.execute(
            update(Job).where(Job.id == job_id).values(leased_until=utcnow() - timedelta(1))
        )


def test_a_job_whose_worker_keeps_dying_fails_after_the_cap_and_the_next_job_runs(
    sessions: sessionmaker[Session],
) -> None:
    poison, healthy = add_jobs(sessions, 2)
    with sessions.begin() as session:  # the poison job is first in line
        session.execute(
            update(Job).where(Job.id == poison).values(run_after=utcnow() - timedelta(1))
        )
    queue = make_queue(sessions, max_attempts=5)
    for attempt in range(1, 6):
        claim = queue.claim(f"w{attempt}")
        assert claim is not None and claim.job_id == poison and claim.attempts == attempt
        _lapse(sessions, poison)  # killed while describing

    nxt = queue.claim("survivor")
    assert nxt is not None and nxt.job_id == healthy and nxt.attempts == 1
    job = job_row(sessions, poison)
    assert job.status == "failed" and job.attempts == 5
    assert job.last_error["detail"] == "the worker died 5 times while describing this file"
    with sessions() as session:
        model = session.scalars(select(Model).where(Model.id == job.model_id)).one()
        assert model.status == "failed"
        assert model.error["type"] == "urn:shapesearch:problem:worker-died"
    assert queue.complete(nxt, RESULT)
    assert queue.claim("survivor") is None  # the poison job never comes back


# --- turns among tenants --------------------------------------------------------------------


def claim_order(sessions: sessionmaker[Session], count: int | None = None) -> list[uuid.UUID]:
    """The job ids in the order one worker claims them (each ended before the next),
    ``count`` of them or until the queue is empty."""
    queue, order = make_queue(sessions), []
    while count is None or len(order) < count:
        claim = queue.claim("w")
        if claim is None:
            break
        order.append(claim.job_id)
        assert queue.fail(claim, {"detail": "only the order is asked"})
    return order


def test_a_tenant_with_nothing_queued_waits_for_one_job_not_another_tenants_backlog(
    sessions: sessionmaker[Session],
) -> None:
    """Claimed oldest first, the desk's upload came 21st, after the whole import."""
    backlog = add_jobs(sessions, 20, tenant="bulk")
    first_two = claim_order(sessions, 2)
    (upload,) = add_jobs(sessions, 1, tenant="desk")  # the head has moved on: turn 2
    order = claim_order(sessions)
    assert first_two == backlog[:2]
    assert order.index(upload) == 1  # after bulk's job of the same turn, queued earlier
    assert [job for job in order if job != upload] == backlog[2:]  # bulk's order is kept


def test_backlogged_tenants_are_served_in_turn(sessions: sessionmaker[Session]) -> None:
    bulk = add_jobs(sessions, 12, tenant="bulk")
    other = add_jobs(sessions, 6, tenant="other")  # queued after all of bulk's
    order = claim_order(sessions)
    assert order[:12] == [job for pair in zip(bulk[:6], other, strict=True) for job in pair]
    assert order[12:] == bulk[6:]


def test_a_retried_job_keeps_its_turn(sessions: sessionmaker[Session]) -> None:
    first, *rest = add_jobs(sessions, 3, tenant="bulk")
    queue = make_queue(sessions)
    claim = queue.claim("w")
    assert claim is not None and claim.job_id == first
    assert queue.release(claim)  # a worker shutting down hands it back
    (late,) = add_jobs(sessions, 1, tenant="desk")
    assert claim_order(sessions) == [first, late, *rest]


def test_a_job_waiting_out_a_back_off_does_not_hold_the_head_back(
    sessions: sessionmaker[Session],
) -> None:
    """A newcomer joins the round where it stands, not at the turn of a deferred job."""
    (deferred,) = add_jobs(sessions, 1, tenant="slow")  # turn 0
    backlog = add_jobs(sessions, 12, tenant="bulk")  # turns 0..11
    queue = make_queue(sessions)
    claim = queue.claim("w")
    assert claim is not None and claim.job_id == deferred
    assert queue.defer(claim, {"detail": "storage full"}, seconds=600)
    done = claim_order(sessions, 6)  # bulk's turns 0..5: the round stands at turn 6
    desk = add_jobs(sessions, 3, tenant="desk")
    order = claim_order(sessions)
    assert done == backlog[:6]
    # Turns 6, 7, 8: one desk job after each of bulk's; from the deferred job's turn 0 all
    # three would have gone first.
    assert order[:6] == [job for pair in zip(backlog[6:9], desk, strict=True) for job in pair]
    assert deferred not in order  # still waiting out its back-off


@pytest.mark.slow
def test_a_catalogue_redescribe_takes_turns_with_the_tenants_own_uploads(
    sessions: sessionmaker[Session],
) -> None:
    """With turns among tenants only, the upload came 21st: after the tenant's whole
    catalogue, which the operator had queued for re-describing before it."""
    add_jobs(sessions, 20, tenant="desk")
    claim_order(sessions)  # the first describes end (how, does not matter here)
    catalogue = enqueue_models(sessions, from_version=None, everything=True, current="next")
    first_two = claim_order(sessions, 2)
    (upload,) = add_jobs(sessions, 1, tenant="desk")
    order = claim_order(sessions)
    assert len(catalogue) == 20 and first_two == catalogue[:2]
    assert order.index(upload) == 1  # after the re-describe job of the same turn
    assert [job for job in order if job != upload] == catalogue[2:]  # in the catalogue's order
    with sessions() as session:
        assert session.get(Job, upload).background is False  # type: ignore[union-attr]
        assert session.get(Job, catalogue[0]).background is True  # type: ignore[union-attr]


@pytest.mark.slow
def test_migrations_0011_and_0012_go_up_and_down(database_url: str) -> None:
    """Jobs queued before turns all get turn 0 and so keep their order, oldest first; they
    are requests, not background jobs."""
    engine = make_engine(database_url)
    jobs_0010 = Table(  # the columns a job needs at revision 0010 (no turn)
        "jobs", MetaData(), Column("id", Uuid), Column("model_id", Uuid),
        Column("tenant", String), Column("kind", String), Column("status", String),
        Column("attempts", Integer), Column("run_after", UTCDateTime),
        Column("created_at", UTCDateTime), Column("updated_at", UTCDateTime),
    )
    now, ids = utcnow(), [uuid.uuid4() for _ in range(3)]
    try:
        upgrade(engine, "0010")
        with engine.begin() as connection:
            connection.execute(jobs_0010.insert(), [
                {"id": job_id, "model_id": None, "tenant": tenant, "kind": "duplicates",
                 "status": "queued", "attempts": 0, "run_after": now - timedelta(seconds=age),
                 "created_at": now, "updated_at": now}
                for job_id, tenant, age in zip(ids, ("a", "a", "b"), (30, 20, 10), strict=True)
            ])
        upgrade(engine)
        sessions = make_session_factory(engine)
        with sessions() as session:
            assert set(session.scalars(select(Job.turn))) == {0}
            assert set(session.scalars(select(Job.background))) == {False}
        assert claim_order(sessions) == ids
        config = alembic_config()
        with engine.connect() as connection:
            config.attributes["connection"] = connection
            command.downgrade(config, "0010")
            connection.commit()
        for table in ("jobs", "webhook_deliveries"):
            assert "turn" not in {c["name"] for c in inspect(engine).get_columns(table)}
        assert "background" not in {c["name"] for c in inspect(engine).get_columns("jobs")}
        upgrade(engine)
        for table in ("jobs", "webhook_deliveries"):
            assert "turn" in {c["name"] for c in inspect(engine).get_columns(table)}
        assert "background" in {c["name"] for c in inspect(engine).get_columns("jobs")}
    finally:
        engine.dispose()
