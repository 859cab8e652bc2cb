"""How long the database keeps what is finished: settled jobs, webhook deliveries and the
change feed's old events.

Every upload, re-describe and catalogue re-describe adds a job and a change-feed event
(``app.db.feed``), and every model event adds a delivery per subscribed endpoint with its
attempts; once settled (a job ``done`` or ``failed``, a delivery ``delivered`` or
``failed``, an event applied by every index) they are history. Without an end, the three
tables grow with the service's age rather than its catalogue: a catalogue of 10^5 parts
re-described for each of a few releases and watched by three endpoints holds about a
million rows of history after a year.

``prune_history`` deletes those older than ``SHAPESEARCH_HISTORY_DAYS`` (30; 0 keeps them
all). It keeps, whatever its age,

* a model's newest job: the model's resource shows it (``job``), and it tells why the
  model failed;
* every job and delivery not yet settled (queued, running, pending or being sent);
* each tenant's newest event: it tells whether the tenant's stored duplicates reports are
  stale (``app.search.duplicate_reports``).

A deleted job's ``GET /v1/jobs/{id}`` is a 404 ``job-not-found``; a deleted delivery leaves
its endpoint's deliveries list with its attempts. Deleting events records the newest revision
deleted (``feed_state.pruned_through``) in the same transaction; a search index whose
revision is behind it (one that stopped following for the whole retention) rebuilds from
the models instead of following the feed. Rows go in short transactions of ``batch`` with
a pause after each, so that a writer waits for one batch at most, never for a whole year's
history.

Every process that runs job workers runs a ``HistoryPruner``: once at start, then every
``interval`` seconds. Processes pruning at the same time delete disjoint rows or find them
gone; either is harmless.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Any

from sqlalchemy import ColumnElement, and_, delete, exists, or_, select, true, tuple_, update
from sqlalchemy.orm import Session, aliased, sessionmaker

from app.db.models import FeedState, IndexEvent, Job, WebhookDelivery, utcnow
from app.db.session import pause_for_writers, rows_changed
from app.observability.metrics import HISTORY_PRUNED

__all__ = ["HistoryPruner", "Pruned", "prune_history"]

log = logging.getLogger("shapesearch.retention")

SETTLED_JOBS = ("done", "failed")
SETTLED_DELIVERIES = ("delivered", "failed")


@dataclass(frozen=True)
class Pruned:
    """Rows one pass deleted (a delivery's attempts go with it)."""

    jobs: int
    webhook_deliveries: int
    index_events: int


def prune_history(
    sessions: sessionmaker[Session], days: float, *, batch: int = 1000,
    stop: threading.Event | None = None, now: datetime | None = None,
) -> Pruned:
    """Delete jobs and webhook deliveries settled, and change-feed events made, more than
    ``days`` ago.

    Parameters
    ----------
    sessions : sessionmaker
        The service database.
    days : float
        Age of the history kept; 0 keeps everything (nothing is deleted).
    batch : int
        Rows per transaction.
    stop : threading.Event, optional
        Set: the pass ends after the batch in progress.
    now : datetime, optional
        The present (UTC), for tests; default the clock's.

    Returns
    -------
    Pruned
        How many rows of each table went.
    """
    if days <= 0:
        return Pruned(jobs=0, webhook_deliveries=0, index_events=0)
    before = (now or utcnow()) - timedelta(days=days)
    stop = stop or threading.Event()
    jobs = sum(
        _delete_in_batches(sessions, Job, status, before, _not_a_models_newest(), batch, stop)
        for status in SETTLED_JOBS
    )
    deliveries = sum(
        _delete_in_batches(sessions, WebhookDelivery, status, before, true(), batch, stop)
        for status in SETTLED_DELIVERIES
    )
    events = _prune_feed(sessions, before, batch, stop)
    HISTORY_PRUNED.labels("jobs").inc(jobs)
    HISTORY_PRUNED.labels("webhook_deliveries").inc(deliveries)
    HISTORY_PRUNED.labels("index_events").inc(events)
    return Pruned(jobs=jobs, webhook_deliveries=deliveries, index_events=events)


def _not_a_models_newest() -> ColumnElement[bool]:
    """A job that is not its model's newest (a job about no one model, a duplicates
    report's, has nothing to keep it)."""
    newer = aliased(Job)
    # "Newest" as ``app.ingest.revisions.latest_jobs`` orders: by created_at, then id.
    has_newer = exists().where(
        newer.model_id == Job.model_id,
        tuple_(newer.created_at, newer.id) > tuple_(Job.created_at, Job.id),
    )
    return or_(Job.model_id.is_(None), has_newer)


def _delete_in_batches(
    sessions: sessionmaker[Session], table: type[Job] | type[WebhookDelivery], status: str,
    before: datetime, keep_unless: ColumnElement[bool], batch: int, stop: threading.Event,
) -> int:
    """Delete the rows of ``table`` in ``status`` last updated before ``before`` for which
    ``keep_unless`` holds, ``batch`` at a time.

    The rows are walked once, oldest first, from the (status, updated_at, id) index
    (revision 0014): each read starts after the last one's last row, so a row that stays (a
    model's newest job) is read once a pass, not once a batch. The ids are read outside the
    write (on SQLite a read takes no lock), and the delete checks them again for a row that
    changed since."""
    deleted = 0
    position = tuple_(table.updated_at, table.id)
    prunable = and_(table.status == status, table.updated_at < before, keep_unless)
    oldest_first = select(table.updated_at, table.id).where(prunable)
    oldest_first = oldest_first.order_by(table.updated_at, table.id)
    after: tuple[Any, ...] | None = None
    while not stop.is_set():
        page = oldest_first if after is None else oldest_first.where(position > tuple_(*after))
        with sessions() as session:
            rows = session.execute(page.limit(batch)).all()
        if not rows:
            break
        started = time.monotonic()
        with sessions.begin() as session:
            ids = [row.id for row in rows]
            deleted += rows_changed(session.execute(
                delete(table).where(table.id.in_(ids), prunable)
            ))
        if len(rows) < batch:
            break
        after = tuple(rows[-1])
        pause_for_writers(started, stop)
    return deleted


def _prune_feed(
    sessions: sessionmaker[Session], before: datetime, batch: int, stop: threading.Event
) -> int:
    """Delete the change-feed events made before ``before`` but each tenant's newest,
    ``batch`` at a time, oldest first.

    Revisions commit in order (``app.db.feed``), so the events are walked by revision, their
    primary key, until the first young one. Each transaction also raises
    ``feed_state.pruned_through`` to the newest revision it deleted: an index reads the
    events and then that number (``ShapeIndex.sync``), so it either read a deleted event
    before it went or sees that it went."""
    newer = aliased(IndexEvent)
    # Events of no tenant are from before revision 0010: no report is dated by them.
    not_a_tenants_newest = or_(IndexEvent.tenant.is_(None), exists().where(
        newer.tenant == IndexEvent.tenant, newer.revision > IndexEvent.revision
    ))
    deleted = 0
    after = 0
    while not stop.is_set():
        with sessions() as session:
            rows = session.execute(
                select(IndexEvent.revision, IndexEvent.created_at)
                .where(IndexEvent.revision > after)
                .order_by(IndexEvent.revision)
                .limit(batch)
            ).all()
        old = [row.revision for row in rows if row.created_at < before]
        if not old:
            break
        started = time.monotonic()
        with sessions.begin() as session:
            gone = session.execute(
                delete(IndexEvent)
                .where(IndexEvent.revision.in_(old), not_a_tenants_newest)
                .returning(IndexEvent.revision)
            ).scalars().all()
            if gone:
                newest_gone = max(gone)
                session.execute(
                    update(FeedState)
                    .where(FeedState.id == 1, FeedState.pruned_through < newest_gone)
                    .values(pruned_through=newest_gone)
                )
            deleted += len(gone)
        if len(old) < batch:  # a young event, or the feed's end
            break
        after = old[-1]
        pause_for_writers(started, stop)
    return deleted


class HistoryPruner:
    """A daemon thread that prunes at start and every ``interval`` seconds.

    Parameters
    ----------
    sessions : sessionmaker
        The service database.
    days : float
        ``SHAPESEARCH_HISTORY_DAYS``; 0: the thread is not started.
    interval : float
        Seconds between passes.
    """

    def __init__(
        self, sessions: sessionmaker[Session], days: float, interval: float = 3600.0
    ) -> None:
        self.sessions = sessions
        self.days = days
        self.interval = interval
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self._run, name="history-pruner", daemon=True)

    def start(self) -> HistoryPruner:
        if self.days > 0:
            self.thread.start()
        return self

    def stop(self) -> None:
        self.stopping.set()
        if self.thread.is_alive():
            self.thread.join()

    def _run(self) -> None:
        while not self.stopping.is_set():
            try:
                pruned = prune_history(self.sessions, self.days, stop=self.stopping)
                if pruned.jobs or pruned.webhook_deliveries or pruned.index_events:
                    log.info("history older than %g days pruned: %d jobs, %d webhook "
                             "deliveries, %d change-feed events", self.days, pruned.jobs,
                             pruned.webhook_deliveries, pruned.index_events)
            except Exception as error:  # the database is away: the next pass tries again
                log.warning("history pruning failed, next try in %.0f s: %s",
                            self.interval, error)
            self.stopping.wait(self.interval)
