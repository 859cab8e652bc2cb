"""Prometheus metrics: what ``GET /metrics`` shows (prometheus-client, text format).

Process metrics, counted as things happen (module-level, one set per process):

    shapesearch_http_requests_total{method,route,status}        requests by route template
    shapesearch_http_request_duration_seconds{method,route}     latency histogram
    shapesearch_describe_seconds{stage}                          seconds per describe stage
    shapesearch_solver_calls_total                               eigen-solver calls
    shapesearch_cutoff_n                                         eigenpairs chosen per model
    shapesearch_webhook_delivery_attempts_total{outcome}         delivered / retry / failed

State metrics, read from the database when scraped (``StateCollector``, one per app):

    shapesearch_jobs{status}                                     jobs by status
    shapesearch_queue_depth                                      jobs queued
    shapesearch_queue_oldest_age_seconds                         age of the oldest queued job
    shapesearch_index_partition_models{tenant,descriptor_version}  ready models per partition
    shapesearch_index_models                                     models in this process's index

Describe metrics are observed where the describe runs: the API process for searches and
embedded workers; ``shapesearch worker`` processes keep their own (not exported).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

from prometheus_client import (
    CONTENT_TYPE_LATEST,
    REGISTRY,
    CollectorRegistry,
    Counter,
    Histogram,
    generate_latest,
)
from prometheus_client.core import GaugeMetricFamily
from prometheus_client.registry import Collector
from sqlalchemy import func, select
from sqlalchemy.orm import Session, sessionmaker
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.db.models import Job, Model, utcnow
from app.search.index import ShapeIndex
from core.cutoff import CutoffRecord

__all__ = [
    "CONTENT_TYPE_LATEST",
    "WEBHOOK_ATTEMPTS",
    "HttpMetrics",
    "StateCollector",
    "exposition",
    "observe_description",
]

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
CUTOFF_N = Histogram(
    "shapesearch_cutoff_n", "Eigenpairs the cutoff chose per described shape.",
    buckets=(10, 20, 30, 50, 75, 100, 150, 200, 300, 500),
)


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


class StateCollector(Collector):
    """Queue, job and index state of one app, read from its database at scrape time."""

    def __init__(self, sessions: sessionmaker[Session], index: ShapeIndex) -> None:
        self.sessions = sessions
        self.index = index

    def collect(self) -> Iterator[GaugeMetricFamily]:
        with self.sessions() as session:
            jobs: dict[str, int] = dict(
                session.execute(select(Job.status, func.count()).group_by(Job.status)).all()
            )
            oldest = session.scalar(
                select(func.min(Job.created_at)).where(Job.status == "queued")
            )
            partitions = session.execute(
                select(Model.tenant, Model.descriptor_version, func.count())
                .where(Model.status == "ready")
                .group_by(Model.tenant, Model.descriptor_version)
            ).all()
        by_status = GaugeMetricFamily("shapesearch_jobs", "Jobs by status.", labels=["status"])
        for status in ("queued", "running", "done", "failed"):
            by_status.add_metric([status], jobs.get(status, 0))
        yield by_status
        yield GaugeMetricFamily("shapesearch_queue_depth", "Jobs queued.", jobs.get("queued", 0))
        age = 0.0 if oldest is None else max(0.0, (utcnow() - oldest).total_seconds())
        yield GaugeMetricFamily(
            "shapesearch_queue_oldest_age_seconds", "Age of the oldest queued job.", age
        )
        sizes = GaugeMetricFamily(
            "shapesearch_index_partition_models",
            "Ready models per search partition (tenant, descriptor version).",
            labels=["tenant", "descriptor_version"],
        )
        for tenant, version, count in partitions:
            sizes.add_metric([tenant, version or ""], count)
        yield sizes
        yield GaugeMetricFamily(
            "shapesearch_index_models", "Models in this process's search index.", len(self.index)
        )


def exposition(state: CollectorRegistry) -> bytes:
    """The text format of the process metrics followed by one app's state metrics."""
    return generate_latest(REGISTRY) + generate_latest(state)
