"""Benchmark: ``GET /v1/webhooks/{id}/deliveries`` on an endpoint with a long history.

A new SQLite database (or ``--database-url``) with one endpoint and ``--deliveries`` settled
deliveries of it (written in bulk, a second apart, as months of ``model.ready`` events of a
busy catalogue leave them), then the newest ``--limit`` are listed through the API
(``TestClient`` over the app, no workers) ``--repeat`` times: with the endpoint-and-time
index (``ix_webhook_deliveries_endpoint_created``, revision 0013), then without it (dropped:
the baseline, in the same run). Prints both medians and their ratio.

    .venv/bin/python -m bench.delivery_history [--deliveries 200000] [--repeat 7]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
import uuid
from datetime import timedelta

from fastapi.testclient import TestClient
from sqlalchemy import insert, text

from app.api.main import create_app
from app.db.models import WebhookDelivery, utcnow
from app.db.session import make_engine
from app.settings import Settings


def fill(database_url: str, webhook_id: uuid.UUID, count: int) -> None:
    """``count`` delivered events of the endpoint, oldest first, a second apart."""
    now = utcnow()
    engine = make_engine(database_url)
    with engine.begin() as connection:
        for start in range(0, count, 20000):
            connection.execute(insert(WebhookDelivery), [
                {"id": uuid.uuid4(), "webhook_id": webhook_id, "event_type": "model.ready",
                 "payload": {"type": "model.ready", "data": {"model": {"id": str(uuid.uuid4())}}},
                 "status": "delivered", "attempts": 1, "run_after": now, "turn": number,
                 "created_at": now - timedelta(seconds=count - number), "updated_at": now}
                for number in range(start, min(count, start + 20000))
            ])
    engine.dispose()


def drop_index(database_url: str) -> None:
    engine = make_engine(database_url)
    with engine.begin() as connection:
        connection.execute(text("DROP INDEX ix_webhook_deliveries_endpoint_created"))
    engine.dispose()


def listing_seconds(client: TestClient, path: str, repeat: int) -> list[float]:
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        response = client.get(path)
        times.append(time.perf_counter() - started)
        response.raise_for_status()
    return times


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--deliveries", type=int, default=200000)
    parser.add_argument("--limit", type=int, default=50)
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--database-url", help="default: a new SQLite file")
    args = parser.parse_args()
    folder = tempfile.mkdtemp()
    database_url = args.database_url or f"sqlite:///{folder}/bench.db"
    settings = Settings(database_url=database_url, data_dir=folder,
                        webhook_allow_private=True)
    with TestClient(create_app(settings, embedded_worker=False)) as client:
        hook = client.post("/v1/webhooks", json={"url": "http://127.0.0.1:9/hook",
                                                 "events": ["model.ready"]})
        hook.raise_for_status()
        webhook_id = uuid.UUID(hook.json()["id"])
        fill(database_url, webhook_id, args.deliveries)
        path = f"/v1/webhooks/{webhook_id}/deliveries?limit={args.limit}"
        listing_seconds(client, path, 1)  # warm
        indexed = listing_seconds(client, path, args.repeat)
        drop_index(database_url)
        listing_seconds(client, path, 1)
        scanned = listing_seconds(client, path, args.repeat)
    with_index, without = statistics.median(indexed), statistics.median(scanned)
    print(f"newest {args.limit} of {args.deliveries} deliveries of one endpoint, "
          f"{args.repeat} requests each:")
    print(f"  with ix_webhook_deliveries_endpoint_created: median {with_index * 1000:8.1f} ms")
    print(f"  without it (the baseline):                  median {without * 1000:8.1f} ms, "
          f"{without / with_index:.0f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
