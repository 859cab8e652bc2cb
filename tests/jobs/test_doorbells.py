"""Doorbells (``app.db.doorbells``): the commit that creates work wakes its waiters at once.

Every waiter here polls once a minute, so only a ring can make it act within seconds: a
worker claims a queued job, an API process without workers finds a model another process
made ready, a deliverer sends a webhook. A rolled-back change rings nothing; on PostgreSQL
a listener carries the ring from another process (its own bell, not the test's).
"""

from __future__ import annotations

import threading
import time
import uuid
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy import text
from sqlalchemy.orm import Session, sessionmaker

import app.jobs.turns
from app.db.doorbells import FEED, JOBS, Doorbell, Listener, _Neighbours
from app.db.feed import record_event
from app.db.models import Model
from app.db.session import make_engine, make_session_factory, open_sessions
from app.jobs.queue import JobQueue
from app.jobs.turns import queue_job
from app.jobs.worker import WorkerPool
from tests.conftest import PARTS, fake_describe, upload
from tests.jobs.test_queue import RESULT, add_jobs, make_queue
from tests.plm_helpers import Receiver, started_clients

MINUTE = 60.0  # every waiter's poll: longer than any test waits


class _WatchedDoorbell(Doorbell):
    """A doorbell that tells when a waiter has started waiting on it (is idle)."""

    def __init__(self, channel: str) -> None:
        super().__init__(channel)
        self.idle = threading.Event()

    def wait(self, timeout: float) -> bool:
        self.idle.set()
        return super().wait(timeout)


def _idle_pool(
    sessions: sessionmaker[Session], doorbell: Doorbell, handled: threading.Event
) -> WorkerPool:
    def quick(content: bytes, filename: str) -> dict[str, Any]:
        handled.set()
        return RESULT

    return WorkerPool(make_queue(sessions), quick, count=1, poll_interval=MINUTE,
                      doorbell=doorbell)


def _model(tenant: str = "t") -> Model:
    return Model(id=uuid.uuid4(), tenant=tenant, meta={}, status="queued", file_name="a.xyz",
                 file_size=1, file_sha256="0" * 64, file_format="xyz")


def test_a_queued_job_wakes_an_idle_worker_at_once(
    sessions: sessionmaker[Session], monkeypatch: pytest.MonkeyPatch
) -> None:
    doorbell = _WatchedDoorbell(JOBS.channel)
    monkeypatch.setattr(app.jobs.turns, "JOBS", doorbell)  # the bell queue_job announces
    handled = threading.Event()
    pool = _idle_pool(sessions, doorbell, handled)
    pool.start()
    try:
        assert doorbell.idle.wait(10)  # it looked, found nothing and waits
        add_jobs(sessions, 1)
        assert handled.wait(10)
    finally:
        started = time.monotonic()
        pool.stop(grace=30)
    assert time.monotonic() - started < 5  # an idle worker sees the stop at once too
    assert not pool.threads[0].is_alive()


def test_one_commit_of_many_jobs_wakes_every_idle_worker(
    sessions: sessionmaker[Session],
) -> None:
    """An import queues a batch in one commit, one ring: every idle worker wakes (not only
    one) and each takes a job, instead of the second polling."""
    both = threading.Barrier(2, timeout=10)
    released = threading.Event()

    def meet(content: bytes, filename: str) -> dict[str, Any]:
        both.wait()  # returns only when two jobs run at once
        released.set()
        return RESULT

    pool = WorkerPool(make_queue(sessions), meet, count=2, poll_interval=MINUTE)
    pool.start()
    try:
        time.sleep(0.5)  # both idle
        add_jobs(sessions, 2)
        assert released.wait(10)
    finally:
        pool.stop(grace=30)


def test_a_rolled_back_change_rings_nothing(sessions: sessionmaker[Session]) -> None:
    JOBS.clear()
    FEED.clear()
    with sessions() as session:
        model = _model()
        session.add(model)
        session.flush()
        queue_job(session, tenant="t", model_id=model.id)
        record_event(session, 1, "ready", "t")
        session.rollback()
        session.add(_model())
        session.commit()  # a later commit that announces nothing
    assert not JOBS.wait(0) and not FEED.wait(0)
    add_jobs(sessions, 1)
    assert JOBS.wait(0) and not FEED.wait(0)


@pytest.mark.slow
def test_a_job_queued_by_another_process_wakes_a_worker_through_its_listener(
    new_database_url: Any, backend: str
) -> None:
    """The pool's bell is rung only by its listener (PostgreSQL's LISTEN, or on SQLite a
    Unix socket): the test's own commits ring this process's bell, which stands for another
    process's."""
    sessions = open_sessions(new_database_url(backend))
    doorbell = _WatchedDoorbell(JOBS.channel)
    listener = Listener(sessions.kw["bind"], [doorbell])
    handled = threading.Event()
    pool = _idle_pool(sessions, doorbell, handled)
    listener.start()
    pool.start()
    try:
        assert doorbell.idle.wait(10)
        time.sleep(0.5)  # the listener's LISTEN (or socket) is in place
        with sessions() as session:  # rolled back: nothing is sent
            model = _model()
            session.add(model)
            session.flush()
            queue_job(session, tenant="t", model_id=model.id)
            session.rollback()
        time.sleep(1.0)
        assert not handled.is_set()
        add_jobs(sessions, 1)
        assert handled.wait(10)
    finally:
        pool.stop(grace=30)
        listener.stop()
    assert listener.thread is not None and not listener.thread.is_alive()


def test_a_model_made_ready_elsewhere_is_searchable_at_once(database_url: str) -> None:
    """An API process without workers: another process's worker completes two jobs, and
    the first model's similar list holds the second within seconds (the index's own poll
    is a minute away)."""
    with started_clients(database_url) as make:
        api = make(embedded_worker=False, index_sync_interval=MINUTE)
        paths = {}
        for path in (PARTS / "angle_block.STL", PARTS / "round.stl"):
            response = upload(api, path)
            assert response.status_code == 202, response.text
            paths[response.json()["id"]] = path
        first, second = paths
        queue = JobQueue(make_session_factory(make_engine(database_url)), lease_seconds=30,
                         max_attempts=3)
        for _ in paths:
            claim = queue.claim("another-process")
            assert claim is not None
            path = paths[str(claim.model_id)]
            assert queue.complete(claim, fake_describe(path.read_bytes(), path.name))
        deadline = time.monotonic() + 10
        found: list[str] = []
        while time.monotonic() < deadline and second not in found:
            response = api.get(f"/v1/models/{first}/similar?k=5")
            if response.status_code == 200:
                found = [result["model"]["id"] for result in response.json()["results"]]
            time.sleep(0.05)
        assert second in found


@pytest.mark.slow
def test_a_webhook_is_sent_as_soon_as_its_model_is_ready(database_url: str) -> None:
    """Worker and deliverer both poll once a minute: the upload's job and its model.ready
    event are each taken at once because their commits ring."""
    with started_clients(database_url) as make, Receiver() as receiver:
        api = make(poll_interval=MINUTE)
        response = api.post("/v1/webhooks", json={"url": receiver.url, "events": ["model.ready"]})
        assert response.status_code == 201, response.text
        time.sleep(0.5)  # worker and deliverer idle
        model = upload(api, PARTS / "angle_block.STL").json()
        (request,) = receiver.wait_for(1, timeout=10)
        assert model["id"].encode() in request[2]


def test_a_socket_left_by_a_process_that_died_is_removed(new_database_url: Any) -> None:
    """On SQLite the rings go by Unix sockets in a folder of the database's: a process that
    died leaves its socket file, which the next listener to start removes, or else the next
    ring; the living listener still hears it."""
    sessions = open_sessions(new_database_url("sqlite"))
    engine = sessions.kw["bind"]
    neighbours = _Neighbours.of(engine.url)
    assert neighbours is not None

    def left_by_a_dead_process() -> Path:
        dead = neighbours.bind()
        left = Path(dead.getsockname())
        dead.close()  # its process is gone; the file stays
        return left

    before_start = left_by_a_dead_process()
    bell = Doorbell(JOBS.channel)
    listener = Listener(engine, [bell])
    listener.start()
    try:
        assert bell.wait(10)  # its socket is bound: it rings once for work queued before
        assert not before_start.exists()
        meanwhile = left_by_a_dead_process()
        bell.clear()
        add_jobs(sessions, 1)
        assert bell.wait(5)
        assert not meanwhile.exists()
    finally:
        listener.stop()
    assert listener.thread is not None and not listener.thread.is_alive()
    assert not neighbours.folder.exists()  # the last listener took its socket and folder


@pytest.mark.slow
def test_a_listener_whose_connection_is_killed_listens_again(new_database_url: Any) -> None:
    sessions = open_sessions(new_database_url("postgresql"))
    bell = Doorbell(JOBS.channel)
    listener = Listener(sessions.kw["bind"], [bell], retry_seconds=0.2)
    listener.start()
    try:
        deadline = time.monotonic() + 10
        while listener.backend_pid is None and time.monotonic() < deadline:
            time.sleep(0.05)
        killed = listener.backend_pid
        with sessions() as session:
            session.execute(text("SELECT pg_terminate_backend(:pid)"), {"pid": killed})
        while listener.backend_pid == killed and time.monotonic() < deadline:
            time.sleep(0.05)
        assert listener.backend_pid not in (None, killed)  # a new connection listens
        bell.clear()
        add_jobs(sessions, 1)
        assert bell.wait(5)
    finally:
        listener.stop()
