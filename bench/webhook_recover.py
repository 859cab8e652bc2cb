"""Benchmark: ``POST /v1/webhooks/{id}/recover`` of many failed deliveries beside a writer.

A new SQLite database (or ``--database-url``, an empty one) holds one endpoint with
``--deliveries`` failed deliveries (a receiver that was away during a bulk load). While an
upload's transaction (its model, then its job) is written in a loop, ``recover`` queues them
all again: in batches as the service does (``--batch``), and, as the baseline in the same
run, in one transaction (the first version). Prints each one's time and the uploads' median
and worst latency during it, against the uploads' baseline on the idle database.

    .venv/bin/python -m bench.webhook_recover [--deliveries 100000] [--batch 1000]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import uuid
from datetime import timedelta

from sqlalchemy import insert, update
from sqlalchemy.orm import Session, sessionmaker

from app.db.models import Webhook, WebhookDelivery, utcnow
from app.db.session import make_session_factory, migrated_engine
from app.webhooks import recover
from bench.uploads_beside import beside_uploads, upload_once

CHUNK = 20000


def fill(sessions: sessionmaker[Session], deliveries: int) -> uuid.UUID:
    now = utcnow()
    hook = uuid.uuid4()
    with sessions.kw["bind"].begin() as connection:
        connection.execute(insert(Webhook), [{
            "id": hook, "tenant": "t", "url": "https://example.com/hook",
            "events": ["model.ready"], "secret": "whsec_" + "A" * 32, "created_at": now,
        }])
        for start in range(0, deliveries, CHUNK):
            connection.execute(insert(WebhookDelivery), [
                {"id": uuid.uuid4(), "webhook_id": hook, "event_type": "model.ready",
                 "payload": {"type": "model.ready", "data": {"model": {"id": str(number)}}},
                 "status": "failed", "attempts": 20, "turn": number, "run_after": now,
                 "created_at": now - timedelta(seconds=deliveries - number), "updated_at": now}
                for number in range(start, min(deliveries, start + CHUNK))
            ])
    return hook


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--deliveries", type=int, default=100000)
    parser.add_argument("--batch", type=int, default=1000)
    parser.add_argument("--database-url")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as folder:
        url = args.database_url or f"sqlite:///{folder}/recover.db"
        engine = migrated_engine(url)
        sessions = make_session_factory(engine)
        hook = fill(sessions, args.deliveries)
        base = statistics.median([upload_once(sessions) for _ in range(200)])
        print(f"{engine.dialect.name}: {args.deliveries} failed deliveries of one endpoint; "
              f"an upload's transaction on the idle database: median {base * 1e3:.2f} ms")
        for label, batch in (("one transaction (baseline)", args.deliveries + 1),
                             (f"batches of {args.batch}", args.batch)):
            with sessions.begin() as session:  # failed again, for this round
                session.execute(update(WebhookDelivery).values(status="failed", attempts=20))
            count, seconds, during = beside_uploads(
                sessions, lambda batch=batch: recover(sessions, hook, batch=batch)
            )
            assert count == args.deliveries, count
            middle = statistics.median(during)
            print(f"{label}: {seconds:.1f} s; {len(during)} uploads meanwhile, median "
                  f"{middle * 1e3:.2f} ms ({middle / base:.1f}x), worst {max(during):.2f} s")
        engine.dispose()


if __name__ == "__main__":
    main()
