"""The job queue on both backends: exactly-once claiming under concurrency, leases,
take-over of expired leases, retries with backoff, release on shutdown."""

from __future__ import annotations

import threading
import uuid
from collections import Counter
from datetime import timedelta

import pytest
from sqlalchemy import Engine, select, update
from sqlalchemy.orm import Session, sessionmaker

from app.db.migrate import upgrade
from app.db.models import Job, Model, Upload, utcnow
from app.db.session import make_engine, make_session_factory
from app.jobs.lease import backoff_seconds
from app.jobs.queue import Claim, JobQueue

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


def add_jobs(sessions: sessionmaker[Session], count: int) -> list[uuid.UUID]:
    """``count`` queued models with their jobs; returns the job ids."""
    job_ids = []
    with sessions.begin() as session:
        for i in range(count):
            model = Model(
                id=uuid.uuid4(),
                tenant="t",
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
            job = Job(id=uuid.uuid4(), model_id=model.id, tenant="t", status="queued")
            session.add(job)
            job_ids.append(job.id)
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
