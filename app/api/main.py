"""``create_app(settings)``: one independent API instance with everything it owns.

The lifespan applies the migrations, builds the search index from the database, starts the
thread that follows the change feed and, when asked, the embedded workers; on shutdown it
stops them (running jobs finish within the grace time or are released).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import AsyncIterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import asynccontextmanager

from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware
from fastapi_offline import FastAPIOffline

from app.api.deps import Services
from app.api.examples import install_examples
from app.api.hot_reads import HotReads
from app.api.inputs import InputLimits, QueryGuard
from app.api.limits import BodySizeLimit
from app.api.openapi import install_openapi
from app.api.problems import install_problem_handlers
from app.api.response_cache import ResponseCache
from app.api.routes import ROUTERS
from app.api.search_describer import SearchAdmission, SearchDescriber
from app.api.uploads import UploadReader
from app.db.doorbells import FEED, JOBS, WEBHOOKS, Listener
from app.db.retention import HistoryPruner
from app.db.session import make_session_factory, migrated_engine, read_only
from app.ingest.describing import pin_blas_threads
from app.jobs.worker import (
    JobHandler,
    WorkerPool,
    describe_handler,
    duplicates_handler,
    make_queue,
)
from app.observability.logs import Outage, RequestId
from app.observability.metrics import (
    HttpMetrics,
    IndexCollector,
    QueueCollector,
    metrics_registry,
    observe_index,
)
from app.search.index import ShapeIndex
from app.settings import Settings, engine_settings
from app.viewer import install_viewer
from app.webhooks import start_delivery_lanes

__all__ = ["create_app"]

log = logging.getLogger("shapesearch.api")

# Kept neighbourhoods are saved at most this often while parts change (and on shutdown): a
# process that dies instead restores them as they were then, forgetting what changed since.
_SAVE_EVERY = 600.0

# Room for the multipart envelope and the form fields around the file itself.
_FORM_OVERHEAD_BYTES = 64 * 1024


def _sync(index: ShapeIndex) -> None:
    """Catch up with the change feed, and show the index's size and warmth in the metrics."""
    index.sync()
    _observe(index)


def _observe(index: ShapeIndex) -> None:
    observe_index(len(index), index.neighbourhoods_kept())


def _follow_feed(index: ShapeIndex, interval: float, stop: threading.Event) -> None:
    """Sync when the feed's doorbell rings (a model became ready or went, in this process
    or in another: ``app.db.doorbells``) and at least every ``interval`` seconds; once a
    sync finds nothing new and the index wants its hub-discount neighbourhoods (after
    start-up, or after a bulk change forgot them), restore or compute them in the
    background (``ShapeIndex.keep_neighbourhoods``), and save them at most every
    ``_SAVE_EVERY`` seconds while they change (``ShapeIndex.save_neighbourhoods``)."""
    keeper: threading.Thread | None = None
    saved_at = time.monotonic()
    outage = Outage(log, "index sync: the change feed")
    while not stop.is_set():
        FEED.wait(interval)
        if stop.is_set():
            break
        FEED.clear()  # before the sync: a ring during it is kept for the next wait
        changes = index.changes
        try:
            _sync(index)
            outage.end()
        except Exception as error:
            outage.report(error)
            continue
        quiet = index.changes == changes
        if not quiet or (keeper is not None and keeper.is_alive()):
            continue
        task = None
        if index.wants_neighbourhoods():
            task = _keep_neighbourhoods
        elif time.monotonic() - saved_at >= _SAVE_EVERY:
            task, saved_at = _save_neighbourhoods, time.monotonic()
        if task is not None:
            keeper = threading.Thread(target=task, args=(index,), name="index-neighbourhoods",
                                      daemon=True)
            keeper.start()


def _keep_neighbourhoods(index: ShapeIndex) -> None:
    """Every model's hub-discount neighbourhood, restored or computed (and then saved) in
    the background so that similar queries find it kept (until then they compute their
    candidates' own)."""
    started = time.perf_counter()
    try:
        kept = index.keep_neighbourhoods()
    except Exception:  # the queries compute what they need instead
        log.exception("computing the hub-discount neighbourhoods failed")
        return
    # Said when done: a process waiting for another's pass looks again at each quiet sync.
    level = logging.DEBUG if index.wants_neighbourhoods() else logging.INFO
    log.log(level, "hub-discount neighbourhoods of %d models kept in %.1f s", kept,
            time.perf_counter() - started)
    _observe(index)


def _save_neighbourhoods(index: ShapeIndex) -> None:
    """Save the kept neighbourhoods that changed (``ShapeIndex.save_neighbourhoods``), so
    that a restart restores them."""
    try:
        index.save_neighbourhoods()
    except Exception:  # a restart computes them instead
        log.exception("saving the hub-discount neighbourhoods failed")


def create_app(
    settings: Settings | None = None,
    *,
    embedded_worker: bool = False,
    job_handler: JobHandler | None = None,
) -> FastAPI:
    """Build an app. ``embedded_worker`` runs ``settings.worker_count`` worker threads inside it;
    ``job_handler`` replaces the describe step (tests)."""
    settings = settings or Settings()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        pin_blas_threads()
        engine = migrated_engine(settings.resolved_database_url)
        sessions = make_session_factory(engine)
        index = ShapeIndex(sessions, **settings.index_options)
        index.rebuild()
        _observe(index)
        log.info("index built: %d models, partitions by kind %s, payload %.0f MB",
                 len(index), index.kinds(), index.nbytes() / 1e6)
        app.state.metrics = metrics_registry(QueueCollector(sessions), IndexCollector(sessions))
        app.state.services = Services(
            settings=settings,
            engine_settings=engine_settings(settings),
            engine=engine,
            sessions=sessions,
            reader=read_only(engine),
            # OpenMP's thread count is per thread: each query thread pins its own, or FAISS
            # fans a 40-vector search out over every core (a quarter of a similar's time).
            queries=ThreadPoolExecutor(
                settings.query_threads, thread_name_prefix="shapesearch-query",
                initializer=pin_blas_threads,
            ),
            index=index,
            uploads=UploadReader(settings),
        )
        stop = threading.Event()
        follower = threading.Thread(
            target=_follow_feed,
            args=(index, settings.index_sync_interval, stop),
            name="index-sync",
            daemon=True,
        )
        follower.start()
        pool = None
        if embedded_worker and settings.worker_count > 0:
            pool = WorkerPool(
                make_queue(settings, sessions),
                job_handler or describe_handler(settings, sessions),
                count=settings.worker_count,
                poll_interval=settings.poll_interval,
                # A finished job is searchable at once in this process.
                on_done=lambda: _sync(index),
                reports=duplicates_handler(settings, sessions),
            )
            pool.start()
            deliveries = start_delivery_lanes(settings, sessions)  # webhooks, next to jobs
            pruner = HistoryPruner(sessions, settings.history_days).start()
        # What other processes write wakes this one's waiters at once (app.db.doorbells).
        listener = Listener(engine, [FEED] if pool is None else [FEED, JOBS, WEBHOOKS])
        listener.start()
        try:
            yield
        finally:
            if pool is not None:
                pool.stop(settings.shutdown_grace_seconds)
                deliveries.stop()
                pruner.stop()
            listener.stop()
            stop.set()
            FEED.ring()  # the follower sees the stop now
            follower.join()
            _save_neighbourhoods(index)  # what the next start restores
            app.state.services.queries.shutdown()
            app.state.services.reader.dispose()
            engine.dispose()

    # Swagger UI and ReDoc from assets shipped in a wheel: the docs work without internet.
    app = FastAPIOffline(
        title="shapesearch",
        version="1",
        summary="Shape-similarity search for engineering parts.",
        description="Upload meshes and scans; a worker computes a spectral shape descriptor; "
        "ask for the most similar parts. Errors are RFC 9457 application/problem+json.",
        lifespan=lifespan,
        # operationId = the route function's name (upload_model, similar_models, ...):
        # readable and stable for generated clients.
        generate_unique_id_function=lambda route: route.name,
    )
    install_problem_handlers(app)
    app.state.search_describer = SearchDescriber(settings, engine_settings(settings))
    # Innermost: the plain similar and list requests without FastAPI's routing and
    # dependencies (app.api.hot_reads), then the cache: a hit skips routing, auth and the
    # database, but not the metrics and logs.
    app.add_middleware(HotReads)
    app.add_middleware(
        ResponseCache,
        # Never longer than a key lookup is trusted: a revoked key stops within that time.
        seconds=min(settings.response_cache_seconds, settings.auth_cache_seconds),
        index_changes=lambda: app.state.services.index.changes,
    )
    app.add_middleware(SearchAdmission, describer=app.state.search_describer)
    app.add_middleware(
        BodySizeLimit,
        max_upload_bytes=settings.max_upload_bytes,
        overhead_bytes=_FORM_OVERHEAD_BYTES,
    )
    app.add_middleware(QueryGuard, limits=InputLimits.from_settings(settings))
    app.add_middleware(HttpMetrics)
    app.add_middleware(RequestId)  # every line of the request carries its id
    if settings.cors_origin_list:
        # Outermost: a browser's preflight is answered before auth (it carries no key).
        app.add_middleware(
            CORSMiddleware,
            allow_origins=settings.cors_origin_list,
            allow_methods=["GET", "POST", "PUT", "PATCH", "DELETE"],
            allow_headers=["Authorization", "Content-Type", "Idempotency-Key", "If-None-Match"],
            expose_headers=["Location", "Retry-After", "ETag", "Idempotent-Replayed",
                            "X-Request-Id"],
            max_age=600,
        )
    for router in ROUTERS:
        app.include_router(router)
    install_viewer(app)
    install_openapi(app, InputLimits.from_settings(settings))
    install_examples(app)
    return app
