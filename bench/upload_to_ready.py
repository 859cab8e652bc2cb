"""Benchmark: how long an upload takes to be ready on an idle service, against its describe.

Starts the service on a temporary data directory and a free port, subscribes a webhook
endpoint on 127.0.0.1 to ``model.ready``, then uploads every STL part of
``tests/fixtures/parts`` (9) one at a time, ``--rounds`` times, each time polling
``GET /v1/models/{id}`` every 10 ms until it is ready. Per upload it keeps the seconds from
sending the file to seeing ``ready`` and to the ``model.ready`` event's arrival (what a PLM
system that waits for the event sees), and the describe's own seconds (the model's
``timings.total``, measured inside the worker in the same run: the baseline). It prints the
medians and the medians of the per-upload ratios to the describe: what a user waits beyond
the work itself (the wake-ups, the sandbox, the database).

Deployments:

- default: ``shapesearch serve`` with no settings (SQLite, the worker in-process);
- ``--separate-worker``: ``shapesearch serve --no-worker`` and one ``shapesearch worker``
  process on the same database (set ``SHAPESEARCH_DATABASE_URL`` to PostgreSQL for the
  scale-out layout; on SQLite the processes ring each other by Unix sockets).

Usage::

    .venv/bin/python -m bench.upload_to_ready [--rounds 2]
    SHAPESEARCH_DATABASE_URL=postgresql+psycopg://postgres@127.0.0.1:5432/bench \\
        .venv/bin/python -m bench.upload_to_ready --separate-worker
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import httpx

from bench._common import PARTS, shapesearch
from tests.plm_helpers import Receiver


def upload_until_ready(
    client: httpx.Client, path: Path, receiver: Receiver
) -> tuple[float, float, float]:
    """Seconds from sending ``path`` to its model being ready, its describe's seconds, and
    seconds from sending it to its ``model.ready`` event's arrival at ``receiver``."""
    events = len(receiver.requests)
    started = time.perf_counter()
    response = client.post("/v1/models", files={"file": (path.name, path.read_bytes())})
    response.raise_for_status()
    model_id = response.json()["id"]
    while True:
        model = client.get(f"/v1/models/{model_id}").json()
        if model["status"] in ("ready", "failed"):
            break
        time.sleep(0.01)
    ready = time.perf_counter() - started
    if model["status"] != "ready":
        raise RuntimeError(f"{path.name} failed: {model['error']}")
    while len(receiver.requests) == events:
        time.sleep(0.002)
    return ready, float(model["timings"]["total"]), time.perf_counter() - started


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--separate-worker", action="store_true")
    args = parser.parse_args()
    commands = ([["serve", "--no-worker"], ["worker", "--concurrency", "1"]]
                if args.separate_worker else [["serve"]])
    env = {"SHAPESEARCH_LOG_LEVEL": "warning", "SHAPESEARCH_WEBHOOK_ALLOW_PRIVATE": "true"}
    rows: list[tuple[str, float, float, float]] = []
    with (shapesearch(*commands, env=env) as base,
          httpx.Client(base_url=base, timeout=60) as client, Receiver() as receiver):
        client.post("/v1/webhooks", json={"url": receiver.url, "events": ["model.ready"]})
        # Warm: the forkserver, the imports, the webhook client.
        upload_until_ready(client, PARTS / "angle_block.STL", receiver)
        for _ in range(args.rounds):
            for path in sorted(PARTS.glob("*.[sS][tT][lL]")):
                rows.append((path.name, *upload_until_ready(client, path, receiver)))
    layout = "serve --no-worker + 1 worker process" if args.separate_worker else "serve"
    database = "PostgreSQL" if "postgresql" in os.environ.get(
        "SHAPESEARCH_DATABASE_URL", "") else "SQLite"
    print(f"{layout}, {database}; {len(rows)} uploads one at a time; {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.1f}")
    for name, ready, describe, event in rows:
        print(f"  {name:28s} ready {ready:6.3f} s  describe {describe:6.3f} s  "
              f"model.ready received {event:6.3f} s")
    ready_median = statistics.median(row[1] for row in rows)
    describe_median = statistics.median(row[2] for row in rows)
    event_median = statistics.median(row[3] for row in rows)
    print(f"median upload -> ready {ready_median:.3f} s, describe {describe_median:.3f} s, "
          f"beyond the describe {ready_median - describe_median:.3f} s; "
          f"ready / describe median {statistics.median(r[1] / r[2] for r in rows):.2f}x; "
          f"upload -> model.ready received {event_median:.3f} s, "
          f"{statistics.median(r[3] / r[2] for r in rows):.2f}x the describe")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
