"""Benchmark: pruning a year of history (``app.db.retention``) beside a writer.

A new SQLite database (or ``--database-url``, an empty one) holds ``--models`` ready models,
each with ``--history`` settled jobs older than the retention plus its newest job (kept)
and a change-feed event for each of those jobs (the tenant's newest event is kept), and
``--deliveries`` settled webhook deliveries older than the retention with one attempt each.
Then:

1. the baseline: an upload's transaction (its model, then its job: ``bench/uploads_beside.py``)
   on the idle database, ``--writes`` times;
2. the first pass deletes the old history while uploads go on in another thread; their
   latencies meanwhile are what the pruning costs everyone else (SQLite has one writer);
3. a second pass finds nothing to delete: what every later hourly pass costs at this size.

Prints the pass times, rows a second, the uploads' median and worst latency during the pass
against its baseline, and what is left; last, what an idle search index's sync costs now
that it reads ``feed_state.pruned_through`` after the events, against the events' read
alone (all a sync read before the feed was pruned).

    .venv/bin/python -m bench.history_retention [--models 100000] [--history 2]
        [--deliveries 300000] [--batch 1000] [--database-url URL]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
import uuid
from datetime import timedelta

from sqlalchemy import func, insert, select, update
from sqlalchemy.orm import Session, sessionmaker

from app.db.models import (
    FeedState,
    IndexEvent,
    Job,
    Model,
    Webhook,
    WebhookAttempt,
    WebhookDelivery,
    utcnow,
)
from app.db.retention import prune_history
from app.db.session import make_session_factory, migrated_engine
from app.search.index import ShapeIndex
from bench.uploads_beside import beside_uploads, upload_once

CHUNK = 20000


def fill(sessions: sessionmaker[Session], models: int, history: int, deliveries: int) -> None:
    now = utcnow()
    old = now - timedelta(days=400)
    engine = sessions.kw["bind"]
    revision = 0
    with engine.begin() as connection:
        for start in range(0, models, CHUNK):
            ids = [uuid.uuid4() for _ in range(start, min(models, start + CHUNK))]
            events = [
                {"revision": revision + 1 + number, "index_id": start + 1 + number // (history + 1),
                 "kind": "ready", "tenant": "t", "created_at": old}
                for number in range(len(ids) * (history + 1))
            ]
            connection.execute(insert(IndexEvent), events)
            revision += len(events)
            connection.execute(insert(Model), [
                {"id": model_id, "tenant": "t", "meta": {}, "status": "ready",
                 "file_name": "a.stl", "file_size": 1, "file_sha256": "0" * 64,
                 "file_format": "stl", "created_at": old, "updated_at": old}
                for model_id in ids
            ])
            connection.execute(insert(Job), [
                {"id": uuid.uuid4(), "model_id": model_id, "tenant": "t", "kind": "redescribe",
                 "status": "done", "attempts": 1, "turn": 0, "background": False,
                 "run_after": old, "created_at": old + timedelta(days=age),
                 "updated_at": old + timedelta(days=age)}
                for model_id in ids for age in range(history + 1)  # the last one is kept
            ])
        connection.execute(update(FeedState).where(FeedState.id == 1).values(revision=revision))
        webhook_id = uuid.uuid4()
        connection.execute(insert(Webhook), [{
            "id": webhook_id, "tenant": "t", "url": "https://example.com/hook",
            "events": ["model.ready"], "secret": "whsec_" + "A" * 32, "created_at": old,
        }])
        for start in range(0, deliveries, CHUNK):
            ids = [uuid.uuid4() for _ in range(start, min(deliveries, start + CHUNK))]
            connection.execute(insert(WebhookDelivery), [
                {"id": delivery_id, "webhook_id": webhook_id, "event_type": "model.ready",
                 "payload": {"type": "model.ready", "data": {"model": {"id": str(delivery_id)}}},
                 "status": "delivered", "attempts": 1, "turn": 0, "run_after": old,
                 "created_at": old, "updated_at": old}
                for delivery_id in ids
            ])
            connection.execute(insert(WebhookAttempt), [
                {"delivery_id": delivery_id, "attempt": 1, "status_code": 204,
                 "duration_ms": 12.0, "created_at": old}
                for delivery_id in ids
            ])


def counts(sessions: sessionmaker[Session]) -> tuple[int, int, int, int]:
    with sessions() as session:
        return tuple(  # type: ignore[return-value]
            session.scalar(select(func.count()).select_from(table)) or 0
            for table in (Job, WebhookDelivery, WebhookAttempt, IndexEvent)
        )


def idle_sync(sessions: sessionmaker[Session], repeats: int = 2000) -> tuple[float, float]:
    """Median seconds of an up-to-date index's sync, and of its events' read alone."""
    index = ShapeIndex(sessions)
    index.rebuild()
    syncs, reads = [], []
    for _ in range(repeats):
        started = time.perf_counter()
        index.sync()
        syncs.append(time.perf_counter() - started)
        started = time.perf_counter()
        with sessions() as session:
            session.execute(
                select(IndexEvent.revision, IndexEvent.index_id, IndexEvent.kind)
                .where(IndexEvent.revision > index.revision)
                .order_by(IndexEvent.revision)
                .limit(5000)
            ).all()
        reads.append(time.perf_counter() - started)
    return statistics.median(syncs), statistics.median(reads)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", type=int, default=100000)
    parser.add_argument("--history", type=int, default=2)
    parser.add_argument("--deliveries", type=int, default=300000)
    parser.add_argument("--batch", type=int, default=1000)
    parser.add_argument("--writes", type=int, default=200)
    parser.add_argument("--database-url")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as folder:
        url = args.database_url or f"sqlite:///{folder}/history.db"
        engine = migrated_engine(url)
        sessions = make_session_factory(engine)
        started = time.perf_counter()
        fill(sessions, args.models, args.history, args.deliveries)
        print(f"{engine.dialect.name}: {args.models} models with {args.history} old jobs "
              f"each and their newest, an event for each of those jobs, {args.deliveries} "
              f"old deliveries with an attempt each (filled in "
              f"{time.perf_counter() - started:.0f} s); rows (jobs, deliveries, attempts, "
              f"events): {counts(sessions)}")

        baseline = [upload_once(sessions) for _ in range(args.writes)]
        pruned, first, during = beside_uploads(
            sessions, lambda: prune_history(sessions, days=30, batch=args.batch)
        )

        started = time.perf_counter()
        again = prune_history(sessions, days=30, batch=args.batch)
        second = time.perf_counter() - started

        rows = pruned.jobs + pruned.webhook_deliveries + pruned.index_events
        base = statistics.median(baseline)
        print(f"first pass: {pruned.jobs} jobs, {pruned.webhook_deliveries} deliveries "
              f"(with their attempts) and {pruned.index_events} events in {first:.1f} s, "
              f"{rows / first:.0f} rows/s (batch {args.batch})")
        middle = statistics.median(during)
        print(f"an upload's transaction: baseline median {base * 1e3:.2f} ms, worst "
              f"{max(baseline) * 1e3:.1f} ms; during the pass ({len(during)} uploads) median "
              f"{middle * 1e3:.2f} ms ({middle / base:.1f}x), worst {max(during) * 1e3:.1f} ms "
              f"({max(during) / base:.0f}x the baseline median)")
        left = again.jobs + again.webhook_deliveries + again.index_events
        print(f"second pass (nothing older left): {left} rows in {second * 1e3:.0f} ms; left "
              f"(jobs, deliveries, attempts, events): {counts(sessions)}")
        sync, read = idle_sync(sessions)
        print(f"an idle index's sync: median {sync * 1e6:.0f} us, its events' read alone "
              f"{read * 1e6:.0f} us ({sync / read:.2f}x)")
        engine.dispose()


if __name__ == "__main__":
    main()
