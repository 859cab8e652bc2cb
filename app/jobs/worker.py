"""Workers: claim a job, do it under a renewed lease, store the result.

A job's kind says what it is: ``describe`` and ``redescribe`` describe an upload
(``JobHandler``), ``duplicates`` computes and stores a tenant's duplicates report
(``ReportHandler``, ``app.search.duplicates``).

    Worker       one thread's loop: claim -> heartbeat while handling -> complete/fail/retry
    WorkerPool   N worker threads with a graceful stop (finish, or release after a grace time)
    run_workers  ``shapesearch worker``: N processes sharing the database, signals handled,
                 and with a metrics port their describe, cutoff, queue and webhook metrics
                 on one HTTP endpoint (the N processes summed)

An idle worker waits on its process's jobs doorbell (``app.db.doorbells``): a job queued in
this process, or announced by another one to the process's ``Listener`` (PostgreSQL's
``NOTIFY``, a Unix socket on a SQLite file), wakes it at once; otherwise it looks again after
``poll_interval``.

A worker never dies on its input: every exception of a job ends that job (failed or
retried) and is logged; a database outage is waited out (``Outage``: logged when it starts,
once a minute while it lasts and when it ends). Full storage (``app.storage``) is nobody's input:
the job goes back to the queue for a minute without spending an attempt, so that a full
disk delays jobs instead of failing them.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import secrets
import signal
import socket
import sys
import threading
import time
from collections.abc import Callable
from contextlib import nullcontext
from types import FrameType
from typing import Any

from prometheus_client import start_http_server
from sqlalchemy.exc import DBAPIError, OperationalError
from sqlalchemy.orm import Session

from app.db.doorbells import JOBS, WEBHOOKS, Doorbell, Listener
from app.db.retention import HistoryPruner
from app.db.session import migrated_engine, open_sessions
from app.ingest.describing import (
    CutoffPredictorCache,
    descriptor_version,
    ingest_columns,
    pin_blas_threads,
)
from app.ingest.sandbox import describe_sandbox
from app.jobs.queue import DUPLICATES, Claim, JobQueue
from app.observability.logs import Outage, configure_logging, first_line, job_context
from app.observability.metrics import (
    QueueCollector,
    metrics_registry,
    observe_description,
    process_exited,
    remove_stale_metrics,
    shared_metrics_directory,
)
from app.problems import problem, reason_kind
from app.search.duplicate_reports import store_report
from app.search.duplicates import DuplicatesQuery, compute_report
from app.settings import Settings, engine_settings
from app.storage import storage_full
from app.webhooks import start_delivery_lanes
from core.errors import InvalidShapeError, SolverError

__all__ = [
    "JobHandler",
    "ReportHandler",
    "Worker",
    "WorkerPool",
    "describe_handler",
    "duplicates_handler",
    "make_queue",
    "run_workers",
]

log = logging.getLogger("shapesearch.worker")

# content, file name -> the Model columns to store
JobHandler = Callable[[bytes, str], dict[str, Any]]
# a duplicates job's claim -> what stores its report, given the session of the completion
ReportHandler = Callable[[Claim], Callable[[Session], object]]

# How long a job waits when storage is full: an operator has to free space.
STORAGE_FULL_DELAY_SECONDS = 60.0
# Worth another attempt later: the numerics, the database or the machine had a bad moment.
TRANSIENT_ERRORS: tuple[type[BaseException], ...] = (
    SolverError,
    OperationalError,
    DBAPIError,
    MemoryError,
    TimeoutError,
    OSError,
)


def describe_handler(settings: Settings, sessions: Any = None) -> JobHandler:
    """The production handler: run the engine with the service's settings, in a sandbox
    (a child process with memory and time limits, the time growing with the file's size:
    ``describe_limit_seconds``), so that a bomb fails its job instead of growing or killing
    the worker. Each part is described with its scan-mode entries
    (``ingest_columns``: the scan descriptor and ``SHAPESEARCH_SCAN_VIEWS`` virtual views).

    With ``sessions`` the adaptive cutoff is predicted from the stored models of the same
    descriptor version (refitted as they arrive); without, or with none stored, it seeds.
    """
    engine = engine_settings(settings)
    cache = None if sessions is None else CutoffPredictorCache(sessions, descriptor_version(engine))

    def handle(content: bytes, filename: str) -> dict[str, Any]:
        predictor = None if cache is None else cache.predictor()
        sandbox = describe_sandbox(settings, len(content))
        return sandbox.run(ingest_columns, content, filename, engine, predictor)

    return handle


def duplicates_handler(settings: Settings, sessions: Any) -> ReportHandler:
    """The production report handler: compute the report of the job's tenant and
    parameters with the service's index settings (``app.search.duplicates``)."""

    def handle(claim: Claim) -> Callable[[Session], object]:
        report = compute_report(
            sessions,
            claim.tenant,
            DuplicatesQuery.from_params(claim.params or {}),
            **settings.index_options,
        )
        steps = ", ".join(f"{step} {seconds:.1f}s" for step, seconds in report.timings.items())
        log.info("job %s: %d group(s) among %d models (%s)", claim.job_id,
                 len(report.groups), report.models, steps)
        return lambda session: store_report(session, claim.tenant, report, claim.job_id)

    return handle


def make_queue(settings: Settings, sessions: Any) -> JobQueue:
    return JobQueue(
        sessions,
        lease_seconds=settings.lease_seconds,
        max_attempts=settings.max_attempts,
        backoff_base=settings.retry_backoff_seconds,
        backoff_cap=settings.retry_backoff_max_seconds,
    )


def new_worker_id(index: int) -> str:
    """Unique per worker thread and start, readable in the jobs table."""
    return f"{socket.gethostname()}:{os.getpid()}:{index}:{secrets.token_hex(3)}"


class Worker:
    """One loop that handles jobs until ``stop`` is set."""

    def __init__(
        self,
        queue: JobQueue,
        handler: JobHandler,
        *,
        worker_id: str,
        poll_interval: float,
        stop: threading.Event,
        on_done: Callable[[], None] | None = None,
        reports: ReportHandler | None = None,
        doorbell: Doorbell = JOBS,
    ) -> None:
        self.queue = queue
        self.handler = handler
        self.reports = reports
        self.worker_id = worker_id
        self.poll_interval = poll_interval
        self.stop = stop
        self.on_done = on_done
        self.doorbell = doorbell
        self.current: Claim | None = None

    def run(self) -> None:
        log.info("worker %s started", self.worker_id)
        outage = Outage(log, f"worker {self.worker_id}: queue")
        while not self.stop.is_set():
            # Cleared before the look: a ring during it is kept for the wait below.
            self.doorbell.clear()
            try:
                found = self.run_once()
                outage.end()
            except Exception as error:  # the database is away or full: wait and try again
                outage.report(error)
                found = False
            if not found:
                self.doorbell.wait(self.poll_interval)
        log.info("worker %s stopped", self.worker_id)

    def run_once(self) -> bool:
        """Handle one due job; False if there was none."""
        claim = self.queue.claim(self.worker_id)
        if claim is None:
            return False
        # One ring may announce many jobs (an import's batch), and a waking worker's clear
        # can take the ring from one whose look had just missed them: ring again, so that
        # every idle worker looks once more instead of waiting out its poll.
        self.doorbell.ring()
        self.current = claim
        try:
            with job_context(claim.job_id):  # the job id on every log line of the job
                self._handle(claim)
        finally:
            self.current = None
        return True

    def _handle(self, claim: Claim) -> None:
        if claim.kind == DUPLICATES:
            self._report(claim)
            return
        upload = self.queue.upload_of(claim)
        if upload is None:  # deleted since it was queued; its job went with it
            return
        content, filename = upload
        started = time.perf_counter()
        with _Heartbeat(self.queue, claim):
            try:
                columns = self.handler(content, filename)
            except InvalidShapeError as error:
                log.info("job %s: invalid shape (%s): %s", claim.job_id, error.reason, error)
                self.queue.fail(
                    claim, problem(reason_kind(error.reason), error.message, reason=error.reason)
                )
                return
            except TRANSIENT_ERRORS as error:
                self._retry(claim, error)
                return
            except Exception as error:  # a bug or an input we did not foresee: retry, capped
                log.exception("job %s attempt %d failed", claim.job_id, claim.attempts)
                self.queue.retry(claim, _error_record(error))
                return
        completed = self._stored(claim, lambda: self.queue.complete(claim, columns))
        if completed is None:
            return
        if completed:
            observe_description(columns)
            log.info("job %s done in %.2fs", claim.job_id, time.perf_counter() - started)
            if self.on_done is not None:
                self.on_done()
        else:
            log.warning("job %s: lease lost, result discarded", claim.job_id)

    def _report(self, claim: Claim) -> None:
        """A duplicates job: compute, then store with the job's completion."""
        if self.reports is None:
            self.queue.fail(claim, problem("internal-error", "this worker computes no reports"))
            return
        with _Heartbeat(self.queue, claim):
            try:
                store = self.reports(claim)
            except TRANSIENT_ERRORS as error:
                self._retry(claim, error)
                return
            except Exception as error:  # a bug: retry, capped
                log.exception("job %s attempt %d failed", claim.job_id, claim.attempts)
                self.queue.retry(claim, _error_record(error))
                return
        completed = self._stored(claim, lambda: self.queue.complete_report(claim, store))
        if completed is None:
            return
        if not completed:
            log.warning("job %s: lease lost, report discarded", claim.job_id)
        elif self.on_done is not None:
            self.on_done()

    def _stored(self, claim: Claim, complete: Callable[[], bool]) -> bool | None:
        """``complete()``'s answer (False: the lease was lost), or None when the storage
        was full and the job was deferred."""
        try:
            return complete()
        except Exception as error:
            if not storage_full(error):
                raise
            self._defer(claim, error)
            return None

    def _retry(self, claim: Claim, error: BaseException) -> None:
        """A transient error: try again later, capped; a full storage does not count."""
        if storage_full(error):
            self._defer(claim, error)
            return
        log.warning("job %s attempt %d: %r", claim.job_id, claim.attempts, error)
        self.queue.retry(claim, _error_record(error))

    def _defer(self, claim: Claim, error: BaseException) -> None:
        """Storage is full: the job waits ``STORAGE_FULL_DELAY_SECONDS``, its attempt given
        back. If even that cannot be written, its lease runs out and it is claimed again."""
        reason = first_line(error)
        log.error("job %s: storage full, the job waits %g s (%s)", claim.job_id,
                  STORAGE_FULL_DELAY_SECONDS, reason)
        record = problem("storage-full", f"storage full, the job waits: {reason}")
        try:
            self.queue.defer(claim, record, STORAGE_FULL_DELAY_SECONDS)
        except Exception as again:
            if not storage_full(again):
                raise


def _error_record(error: BaseException) -> dict[str, str]:
    kind = "solver-error" if isinstance(error, SolverError) else "internal-error"
    return problem(kind, f"{type(error).__name__}: {error}"[:2000])


class _Heartbeat:
    """Renews a claim's lease every third of the lease time while the job runs."""

    def __init__(self, queue: JobQueue, claim: Claim) -> None:
        self.queue = queue
        self.claim = claim
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._beat, name="heartbeat", daemon=True)

    def __enter__(self) -> _Heartbeat:
        self.thread.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.done.set()
        self.thread.join()

    def _beat(self) -> None:
        interval = self.queue.lease.total_seconds() / 3
        while not self.done.wait(interval):
            try:
                if not self.queue.renew(self.claim):
                    log.warning("job %s: lease lost", self.claim.job_id)
                    return
            except Exception:
                log.exception("job %s: lease renewal failed", self.claim.job_id)


class WorkerPool:
    """``count`` worker threads over one queue, woken by ``doorbell``."""

    def __init__(
        self,
        queue: JobQueue,
        handler: JobHandler,
        *,
        count: int,
        poll_interval: float,
        on_done: Callable[[], None] | None = None,
        reports: ReportHandler | None = None,
        doorbell: Doorbell = JOBS,
    ) -> None:
        self.queue = queue
        self.stop_event = threading.Event()
        self.doorbell = doorbell
        self.workers = [
            Worker(
                queue,
                handler,
                worker_id=new_worker_id(index),
                poll_interval=poll_interval,
                stop=self.stop_event,
                on_done=on_done,
                reports=reports,
                doorbell=doorbell,
            )
            for index in range(count)
        ]
        self.threads = [
            threading.Thread(target=worker.run, name=f"worker-{index}", daemon=True)
            for index, worker in enumerate(self.workers)
        ]

    def start(self) -> None:
        for thread in self.threads:
            thread.start()

    def stop(self, grace: float, abort: threading.Event | None = None) -> None:
        """Stop claiming; let running jobs finish within ``grace`` seconds (or until
        ``abort``), then release whatever is still running to other workers."""
        self.stop_event.set()
        self.doorbell.ring()  # idle workers see the stop now, not after their poll
        deadline = time.monotonic() + grace
        for thread in self.threads:
            while thread.is_alive() and time.monotonic() < deadline:
                if abort is not None and abort.is_set():
                    break
                thread.join(0.1)
        for worker in self.workers:
            claim = worker.current
            if claim is not None and self.queue.release(claim):
                log.info("job %s released on shutdown", claim.job_id)


def run_workers(concurrency: int | None = None, metrics_port: int | None = None) -> int:
    """``shapesearch worker``: run ``concurrency`` worker processes until signalled; with a
    ``metrics_port`` (default ``SHAPESEARCH_WORKER_METRICS_PORT``) serve their metrics on
    ``SHAPESEARCH_HOST`` at that port."""
    settings = Settings()
    count = concurrency if concurrency is not None else max(1, settings.worker_count)
    port = metrics_port if metrics_port is not None else settings.worker_metrics_port
    configure_logging(log_format=settings.log_format)
    migrated_engine(settings.resolved_database_url).dispose()
    if count == 1:
        remove_stale_metrics()  # only with a PROMETHEUS_MULTIPROC_DIR of the operator's
        return _worker_process(threads=1, metrics_port=port)

    # Processes, not threads: describing is CPU-bound Python and numpy. With a metrics port
    # they share a metrics directory, set before they start, and this process serves it.
    with shared_metrics_directory() if port is not None else nullcontext():
        return _with_metrics(settings, port, lambda: _run_children(count))


def _run_children(count: int) -> int:
    context = multiprocessing.get_context("spawn")
    children = [context.Process(target=_worker_process, args=(1,)) for _ in range(count)]
    for child in children:
        child.start()

    def forward(signum: int, _frame: FrameType | None) -> None:
        for child in children:
            if child.is_alive() and child.pid is not None:
                os.kill(child.pid, signal.SIGTERM)

    signal.signal(signal.SIGTERM, forward)
    signal.signal(signal.SIGINT, forward)
    for child in children:
        child.join()
        if child.pid is not None:
            process_exited(child.pid)
    return 0


def _with_metrics(settings: Settings, port: int | None, run: Callable[[], int]) -> int:
    """``run()`` while the Prometheus metrics of this process (or, with
    ``PROMETHEUS_MULTIPROC_DIR`` set, of every worker process sharing it) and the queue are
    served at ``http://SHAPESEARCH_HOST:port/metrics`` (any path answers) from a daemon
    thread; without a port just ``run()``. 1 if the port cannot be bound."""
    if port is None:
        return run()
    registry = metrics_registry(QueueCollector(open_sessions(settings.resolved_database_url)))
    try:
        server, thread = start_http_server(port, addr=settings.host, registry=registry)
    except OSError as error:
        print(f"error: cannot serve metrics on {settings.host}:{port}: {error.strerror}",
              file=sys.stderr)  # fmt: skip
        return 1
    log.info("metrics on http://%s:%d/metrics", settings.host, port)
    try:
        return run()
    finally:
        server.shutdown()
        server.server_close()
        thread.join()


def _worker_process(threads: int, metrics_port: int | None = None) -> int:
    """One worker process: first SIGTERM/SIGINT finishes the running job (within the grace
    time), a second one releases it at once. With ``metrics_port`` it serves its metrics."""
    settings = Settings()
    configure_logging(log_format=settings.log_format)
    pin_blas_threads()
    return _with_metrics(settings, metrics_port, lambda: _work(settings, threads))


def _work(settings: Settings, threads: int) -> int:
    """Handle jobs and deliver webhooks until signalled."""
    sessions = open_sessions(settings.resolved_database_url)
    # Jobs and webhook deliveries queued by other processes wake this one (PostgreSQL).
    listener = Listener(sessions.kw["bind"], [JOBS, WEBHOOKS])
    listener.start()
    pool = WorkerPool(
        make_queue(settings, sessions),
        describe_handler(settings, sessions),
        count=threads,
        poll_interval=settings.poll_interval,
        reports=duplicates_handler(settings, sessions),
    )
    requested = threading.Event()
    abort = threading.Event()

    def on_signal(signum: int, _frame: FrameType | None) -> None:
        if requested.is_set():
            abort.set()
        requested.set()
        log.info("signal %d: stopping", signum)

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    pool.start()
    deliveries = start_delivery_lanes(settings, sessions)
    pruner = HistoryPruner(sessions, settings.history_days).start()
    while not requested.wait(0.5):
        pass
    pool.stop(settings.shutdown_grace_seconds, abort)
    deliveries.stop()
    pruner.stop()
    listener.stop()
    return 0
