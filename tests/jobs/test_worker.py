"""The worker loop: it survives any exception of a job, classifies errors, keeps its lease
alive while working and releases its job when stopped."""

from __future__ import annotations

import threading
import time
import uuid
from typing import Any

import pytest
from sqlalchemy import select
from sqlalchemy.orm import Session, sessionmaker

from app.db.models import Job, Model
from app.ingest.sandbox import Sandbox
from app.jobs.worker import Worker, WorkerPool
from core.errors import InvalidShapeError, SolverError
from tests.jobs.test_queue import RESULT, add_jobs, make_queue
from tests.jobs.test_sandbox import segfault


def statuses(sessions: sessionmaker[Session]) -> dict[uuid.UUID, tuple[str, Any]]:
    with sessions() as session:
        rows = session.execute(select(Job.id, Job.status, Model.error).join(Model)).all()
    return {row.id: (row.status, row.error) for row in rows}


@pytest.mark.slow
def test_the_worker_survives_every_kind_of_failure(sessions: sessionmaker[Session]) -> None:
    errors: list[BaseException] = [
        InvalidShapeError("degenerate", "all points on a line"),
        SolverError("did not converge"),
        MemoryError(),
        ValueError("a bug"),
        ZeroDivisionError(),
    ]
    add_jobs(sessions, len(errors) + 1)
    calls = iter(errors)

    def handler(content: bytes, filename: str) -> dict[str, Any]:
        error = next(calls, None)
        if error is not None:
            raise error
        return RESULT

    queue = make_queue(sessions, max_attempts=1)
    worker = Worker(queue, handler, worker_id="w", poll_interval=0.01, stop=threading.Event())
    for _ in range(len(errors) + 1):
        assert worker.run_once()
    assert not worker.run_once()  # nothing left, and the worker is still here

    final = statuses(sessions)
    assert sorted(status for status, _ in final.values()) == ["done"] + ["failed"] * 5
    reasons = [error["type"] for status, error in final.values() if status == "failed"]
    assert "urn:shapesearch:problem:degenerate" in reasons
    assert "urn:shapesearch:problem:solver-error" in reasons


def test_invalid_shapes_fail_at_once_but_transient_errors_retry(
    sessions: sessionmaker[Session],
) -> None:
    add_jobs(sessions, 2)
    outcomes = iter([InvalidShapeError("non_finite", "NaN"), SolverError("later")])

    def handler(content: bytes, filename: str) -> dict[str, Any]:
        raise next(outcomes)

    queue = make_queue(sessions, max_attempts=5)
    worker = Worker(queue, handler, worker_id="w", poll_interval=0.01, stop=threading.Event())
    assert worker.run_once() and worker.run_once()
    final = sorted(
        (status, (error or {}).get("detail")) for status, error in statuses(sessions).values()
    )
    assert final == [("failed", "NaN"), ("queued", None)]


@pytest.mark.slow
def test_a_file_that_crashes_its_reader_fails_its_job_at_once(
    sessions: sessionmaker[Session],
) -> None:
    # A native reader ended by a signal (OpenCascade on a malformed STEP file) fails the same
    # way on every attempt: the job fails at the first, with the upload check's problem.
    add_jobs(sessions, 1)

    def handler(content: bytes, filename: str) -> dict[str, Any]:
        return Sandbox(1024**3, 60).run(segfault)

    queue = make_queue(sessions, max_attempts=5)
    worker = Worker(queue, handler, worker_id="w", poll_interval=0.01, stop=threading.Event())
    assert worker.run_once()
    [(status, error)] = statuses(sessions).values()
    assert status == "failed"
    assert error["type"] == "urn:shapesearch:problem:unparsable"
    assert "SIGSEGV" in error["detail"]


@pytest.mark.slow
def test_the_heartbeat_keeps_a_long_job_leased(sessions: sessionmaker[Session]) -> None:
    add_jobs(sessions, 1)
    started = threading.Event()

    def slow(content: bytes, filename: str) -> dict[str, Any]:
        started.set()
        time.sleep(4.0)  # twice the lease
        return RESULT

    # The heartbeat renews every third of the lease: a lease of 2 s leaves a renewal 1.33 s
    # of slack on a busy machine (0.3 s, then 1 s, each lapsed once under a loaded run).
    queue = make_queue(sessions, lease_seconds=2.0)
    worker = Worker(queue, slow, worker_id="slow", poll_interval=0.01, stop=threading.Event())
    thread = threading.Thread(target=worker.run_once)
    thread.start()
    started.wait(10)
    deadline = time.monotonic() + 3.7
    rival = make_queue(sessions, lease_seconds=2.0)
    while time.monotonic() < deadline:
        assert rival.claim("rival") is None  # the lease never lapses
        time.sleep(0.05)
    thread.join(10)
    assert [status for status, _ in statuses(sessions).values()] == ["done"]


@pytest.mark.slow
def test_stopping_the_pool_releases_a_job_that_does_not_finish(
    sessions: sessionmaker[Session],
) -> None:
    (job_id,) = add_jobs(sessions, 1)
    started = threading.Event()
    finish = threading.Event()

    def stuck(content: bytes, filename: str) -> dict[str, Any]:
        started.set()
        finish.wait(10)
        return RESULT

    pool = WorkerPool(make_queue(sessions), stuck, count=1, poll_interval=0.01)
    pool.start()
    assert started.wait(10)
    pool.stop(grace=0.2)
    with sessions() as session:
        job = session.get(Job, job_id)
        assert job is not None
        assert (job.status, job.attempts, job.worker_id) == ("queued", 0, None)
    finish.set()  # its late result is refused: the job was handed back
    pool.threads[0].join(10)
    with sessions() as session:
        assert session.get(Job, job_id).status == "queued"  # type: ignore[union-attr]


@pytest.mark.slow
def test_stopping_the_pool_lets_a_quick_job_finish(sessions: sessionmaker[Session]) -> None:
    add_jobs(sessions, 1)
    started = threading.Event()

    def quick(content: bytes, filename: str) -> dict[str, Any]:
        started.set()
        time.sleep(0.3)
        return RESULT

    pool = WorkerPool(make_queue(sessions), quick, count=2, poll_interval=0.01)
    pool.start()
    assert started.wait(10)
    pool.stop(grace=10)
    assert [status for status, _ in statuses(sessions).values()] == ["done"]


def test_default_settings_describe_exactly_like_the_engine(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import os

    from app.settings import Settings, engine_settings
    from core.settings import HKS_TIMES, EngineSettings

    for name in [n for n in os.environ if n.startswith("SHAPESEARCH_")]:
        monkeypatch.delenv(name)
    assert engine_settings(Settings()) == EngineSettings()
    # The written-out times (the same version on every CPU), not a grid computed again.
    assert engine_settings(Settings()).descriptor.hks_times is HKS_TIMES


@pytest.mark.slow
def test_workers_default_to_one_describe_per_core(monkeypatch: pytest.MonkeyPatch) -> None:
    import os

    from app.settings import Settings

    monkeypatch.delenv("SHAPESEARCH_WORKERS", raising=False)
    monkeypatch.setattr(os, "cpu_count", lambda: 6)
    assert Settings().worker_count == 6
    assert Settings(workers=0).worker_count == 0  # serve without an embedded worker
    monkeypatch.setenv("SHAPESEARCH_WORKERS", "3")
    assert Settings().worker_count == 3
