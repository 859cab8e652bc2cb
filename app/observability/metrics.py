"""Prometheus metrics: what ``GET /metrics`` and ``shapesearch worker --metrics-port`` show
(prometheus-client, text format).

Process metrics, counted as things happen (module-level, one set per process):

    shapesearch_http_requests_total{method,route,status}        requests by route template
    shapesearch_http_request_duration_seconds{method,route}     latency histogram
    shapesearch_describe_seconds{stage}                          seconds per describe stage
    shapesearch_solver_calls_total                               eigen-solver calls
    shapesearch_cutoff_n                                         eigenpairs chosen per model
    shapesearch_webhook_delivery_attempts_total{outcome}         delivered / retry / failed
    shapesearch_history_pruned_total{table}                     settled jobs / webhook
                                                                 deliveries / change-feed
                                                                 events deleted as older
                                                                 than SHAPESEARCH_HISTORY_DAYS
    shapesearch_uploads_unchecked_total{reason}                  uploads let through without
                                                                 their quick check: busy /
                                                                 timeout (app.api.uploads)
    shapesearch_index_models                                     models in an API process's
                                                                 index (the smallest of them)
    shapesearch_index_neighbourhoods_kept_ratio                  share of its models whose
                                                                 hub-discount neighbourhood
                                                                 the index keeps (the
                                                                 smallest; 1: warm)

State metrics, read from the database when scraped (``QueueCollector``, ``IndexCollector``):

    shapesearch_jobs{status}                                     jobs by status
    shapesearch_queue_depth                                      jobs queued
    shapesearch_queue_oldest_age_seconds                         age of the oldest queued job
    shapesearch_webhook_deliveries{status}                       webhook deliveries by status:
                                                                 pending / sending /
                                                                 delivered / failed
    shapesearch_webhook_oldest_undelivered_age_seconds           age of the oldest event still
                                                                 pending or being sent
    shapesearch_index_partition_models{tenant,descriptor_version}  ready models per partition

Describe metrics are observed where the describe runs: an API process for searches and its
embedded workers, a ``shapesearch worker`` process for its jobs.

Several processes, one scrape (prometheus-client's multiprocess mode). A command that starts
several processes (``serve`` with ``SHAPESEARCH_API_PROCESSES`` > 1, ``shapesearch worker
--concurrency N --metrics-port P``) gives them a shared directory in
``PROMETHEUS_MULTIPROC_DIR`` (``shared_metrics_directory``) before it starts them; each
process then keeps its values in memory-mapped files there, and a scrape sums the files
(``MultiProcessCollector``). The variable must be set before prometheus-client is imported,
which is why only freshly spawned processes use it; a single process keeps the plain
in-memory registry, which also has the ``process_*`` and ``python_*`` metrics that
multiprocess mode cannot give (and setting the variable for one process would take whoever
starts it, for nothing to merge). Counters and histograms are summed over the processes; the
one gauge, ``shapesearch_index_models``, takes the smallest live value (``_index_models``).
State metrics are read from the database, the same in every process, so they need no sharing.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from datetime import datetime
from functools import cache
from pathlib import Path
from typing import Any

from prometheus_client import (
    CONTENT_TYPE_LATEST,
    REGISTRY,
    CollectorRegistry,
    Counter,
    Gauge,
    Histogram,
    generate_latest,
)
from prometheus_client.core import GaugeMetricFamily, Metric
from prometheus_client.multiprocess import MultiProcessCollector, mark_process_dead
from prometheus_client.registry import Collector
from sqlalchemy import func, select
from sqlalchemy.orm import Session, sessionmaker
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.db.models import Job, Model, WebhookDelivery, utcnow
from core.cutoff import CutoffRecord

__all__ = [
    "CONTENT_TYPE_LATEST",
    "HISTORY_PRUNED",
    "MULTIPROCESS_VARIABLE",
    "UNCHECKED_UPLOADS",
    "WEBHOOK_ATTEMPTS",
    "HttpMetrics",
    "IndexCollector",
    "QueueCollector",
    "exposition",
    "metrics_registry",
    "observe_description",
    "observe_index",
    "process_exited",
    "remove_stale_metrics",
    "shared_metrics_directory",
]

#: Where processes keep their values when several are scraped as one (prometheus-client).
MULTIPROCESS_VARIABLE = "PROMETHEUS_MULTIPROC_DIR"

HTTP_REQUESTS = Counter(
    "shapesearch_http_requests", "HTTP requests by route template and status.",
    ["method", "route", "status"],
)
HTTP_SECONDS = Histogram(
    "shapesearch_http_request_duration_seconds", "HTTP request latency by route template.",
    ["method", "route"],
)
DESCRIBE_SECONDS = Histogram(
    "shapesearch_describe_seconds", "Seconds per describe stage.", ["stage"],
    buckets=(0.01, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60, 120, 300),
)
SOLVER_CALLS = Counter("shapesearch_solver_calls", "Eigen-solver calls of finished describes.")
WEBHOOK_ATTEMPTS = Counter(
    "shapesearch_webhook_delivery_attempts",
    "Webhook delivery attempts by outcome: delivered, retry (backing off) or failed (gave up).",
    ["outcome"],
)
UNCHECKED_UPLOADS = Counter(
    "shapesearch_uploads_unchecked",
    "Uploads accepted without their sandboxed quick check, by reason: busy (no check slot "
    "came free in time) or timeout (the check ran out of time); the worker's describe decides.",
    ["reason"],
)
HISTORY_PRUNED = Counter(
    "shapesearch_history_pruned",
    "Settled jobs and webhook deliveries, and change-feed events, deleted as older than "
    "SHAPESEARCH_HISTORY_DAYS, by table (jobs, webhook_deliveries, index_events).",
    ["table"],
)
CUTOFF_N = Histogram(
    "shapesearch_cutoff_n", "Eigenpairs the cutoff chose per described shape.",
    buckets=(10, 20, 30, 50, 75, 100, 150, 200, 300, 500),
)


@cache
def _index_models() -> Gauge:
    """Created on first use, so only processes that hold an index (API processes) have it:
    created at import, every worker process would report an index of 0 models.

    ``livemin``: the API processes each hold a copy of the same index, so their sum means
    nothing; the smallest live one is the process furthest behind the change feed (compare
    with ``shapesearch_index_partition_models``), and a stopped process drops out.
    """
    return Gauge(
        "shapesearch_index_models", "Models in an API process's search index (several "
        "processes: the smallest, the one furthest behind the change feed).",
        multiprocess_mode="livemin",
    )


@cache
def _neighbourhoods_kept() -> Gauge:
    """As ``_index_models``: API processes only, the coldest live one. Below 1, similar
    queries compute the radii of candidates whose neighbourhood is not kept (about 170 ms a
    query at 10^6 models until the background pass has kept them: docs/operations.md)."""
    return Gauge(
        "shapesearch_index_neighbourhoods_kept_ratio", "Share of an API process's indexed "
        "models whose hub-discount neighbourhood it keeps (several processes: the smallest).",
        multiprocess_mode="livemin",
    )


def observe_index(models: int, neighbourhoods_kept: float) -> None:
    """Record the size of this process's search index and the share of its hub-discount
    neighbourhoods kept (after either changed)."""
    _index_models().set(models)
    _neighbourhoods_kept().set(neighbourhoods_kept)


def observe_description(columns: dict[str, Any]) -> None:
    """Record a finished describe (``app.ingest.describing.model_columns``)."""
    for stage, seconds in (columns.get("timings") or {}).items():
        DESCRIBE_SECONDS.labels(stage=stage).observe(float(seconds))
    if columns.get("cutoff"):
        cutoff = CutoffRecord.from_json(columns["cutoff"])
        SOLVER_CALLS.inc(cutoff.solver_calls)
        CUTOFF_N.observe(cutoff.n)


def _route_template(scope: Scope) -> str:
    route = scope.get("route")
    return getattr(route, "path", None) or "unmatched"


class HttpMetrics:
    """ASGI middleware counting requests and their latency by route template (never the
    raw path: ids would make one series per model)."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = time.perf_counter()
        status = 500

        async def send_counted(message: Message) -> None:
            nonlocal status
            if message["type"] == "http.response.start":
                status = int(message["status"])
            await send(message)

        try:
            await self.app(scope, receive, send_counted)
        finally:
            route = _route_template(scope)
            method = scope["method"]
            HTTP_REQUESTS.labels(method=method, route=route, status=str(status)).inc()
            HTTP_SECONDS.labels(method=method, route=route).observe(
                time.perf_counter() - started
            )


class QueueCollector(Collector):
    """Jobs by status and the queue, and the webhook outbox likewise, read from the database
    at scrape time: the same for every process that reads them, so the API and each
    ``shapesearch worker`` export them alike (a dashboard takes ``max``)."""

    def __init__(self, sessions: sessionmaker[Session]) -> None:
        self.sessions = sessions

    def collect(self) -> Iterator[GaugeMetricFamily]:
        with self.sessions() as session:
            jobs: dict[str, int] = dict(
                session.execute(select(Job.status, func.count()).group_by(Job.status)).all()
            )
            oldest = session.scalar(
                select(func.min(Job.created_at)).where(Job.status == "queued")
            )
            deliveries: dict[str, int] = dict(
                session.execute(
                    select(WebhookDelivery.status, func.count()).group_by(WebhookDelivery.status)
                ).all()
            )
            oldest_undelivered = session.scalar(
                select(func.min(WebhookDelivery.created_at)).where(
                    WebhookDelivery.status.in_(("pending", "sending"))
                )
            )
        by_status = GaugeMetricFamily("shapesearch_jobs", "Jobs by status.", labels=["status"])
        for status in ("queued", "running", "done", "failed"):
            by_status.add_metric([status], jobs.get(status, 0))
        yield by_status
        yield GaugeMetricFamily("shapesearch_queue_depth", "Jobs queued.", jobs.get("queued", 0))
        yield GaugeMetricFamily(
            "shapesearch_queue_oldest_age_seconds", "Age of the oldest queued job.", _age(oldest)
        )
        outbox = GaugeMetricFamily(
            "shapesearch_webhook_deliveries", "Webhook deliveries by status.", labels=["status"]
        )
        for status in ("pending", "sending", "delivered", "failed"):
            outbox.add_metric([status], deliveries.get(status, 0))
        yield outbox
        yield GaugeMetricFamily(
            "shapesearch_webhook_oldest_undelivered_age_seconds",
            "Age of the oldest webhook event still pending or being sent (an endpoint that is "
            "down holds its events for their retries).",
            _age(oldest_undelivered),
        )


def _age(since: datetime | None) -> float:
    """Seconds since ``since``; 0 for none."""
    return 0.0 if since is None else max(0.0, (utcnow() - since).total_seconds())


class IndexCollector(Collector):
    """Ready models per search partition, read from the database at scrape time (what every
    API process's index should hold)."""

    def __init__(self, sessions: sessionmaker[Session]) -> None:
        self.sessions = sessions

    def collect(self) -> Iterator[GaugeMetricFamily]:
        with self.sessions() as session:
            partitions = session.execute(
                select(Model.tenant, Model.descriptor_version, func.count())
                .where(Model.status == "ready")
                .group_by(Model.tenant, Model.descriptor_version)
            ).all()
        sizes = GaugeMetricFamily(
            "shapesearch_index_partition_models",
            "Ready models per search partition (tenant, descriptor version).",
            labels=["tenant", "descriptor_version"],
        )
        for tenant, version, count in partitions:
            sizes.add_metric([tenant, version or ""], count)
        yield sizes


class _ThisProcess(Collector):
    """The plain in-memory registry of this process (its metrics and process_*, python_*)."""

    def collect(self) -> Iterable[Metric]:
        return REGISTRY.collect()


def metrics_registry(*state: Collector) -> CollectorRegistry:
    """What one scrape shows: the process metrics, of every process sharing
    ``PROMETHEUS_MULTIPROC_DIR`` when it is set (else of this process), then ``state``.

    The variable is read here, not only at import: the parent of several worker processes
    sets it for its children and exports their files, having none of its own to show.
    """
    registry = CollectorRegistry()
    directory = os.environ.get(MULTIPROCESS_VARIABLE)
    if directory:
        MultiProcessCollector(registry, path=directory)
    else:
        registry.register(_ThisProcess())
    for collector in state:
        registry.register(collector)
    return registry


def exposition(registry: CollectorRegistry) -> bytes:
    """The text format of one scrape of ``registry`` (``metrics_registry``)."""
    return generate_latest(registry)


@contextmanager
def shared_metrics_directory() -> Iterator[str]:
    """``PROMETHEUS_MULTIPROC_DIR`` for the processes started inside the block.

    A directory given in the variable is emptied of the files of earlier runs (a scrape
    would add up their counters); unset, a new temporary directory is made and removed at
    the end. Call ``process_exited`` for each process that ends.
    """
    given = os.environ.get(MULTIPROCESS_VARIABLE)
    if given:
        remove_stale_metrics()
        yield given
        return
    made = tempfile.mkdtemp(prefix="shapesearch-metrics-")
    os.environ[MULTIPROCESS_VARIABLE] = made
    try:
        yield made
    finally:
        del os.environ[MULTIPROCESS_VARIABLE]
        shutil.rmtree(made, ignore_errors=True)


def remove_stale_metrics() -> None:
    """Delete the value files of other processes (earlier runs) from a
    ``PROMETHEUS_MULTIPROC_DIR`` given by the operator; this process's own, made when it
    imported prometheus-client with the variable set, are in use. Unset: nothing to do."""
    given = os.environ.get(MULTIPROCESS_VARIABLE)
    if not given:
        return
    directory = Path(given)
    directory.mkdir(parents=True, exist_ok=True)
    mine = f"_{os.getpid()}.db"
    for stale in directory.glob("*.db"):
        if not stale.name.endswith(mine):
            stale.unlink(missing_ok=True)


def process_exited(pid: int) -> None:
    """A process sharing ``PROMETHEUS_MULTIPROC_DIR`` ended: its live gauges leave the sums
    (its counters and histograms stay: what it counted happened)."""
    directory = os.environ.get(MULTIPROCESS_VARIABLE)
    if directory:
        mark_process_dead(pid, directory)
