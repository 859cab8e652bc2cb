"""Benchmark: ``GET /v1/stats/cutoff`` (the viewer's database page, asked every 3 s) on a
large catalogue.

A new SQLite database with ``--models`` ready models (written in bulk, with cutoff records
and point counts as the worker stores them), then the route through the API (``TestClient``
over the app, no workers) ``--repeat`` times: the median seconds, the answer's size and the
process's peak memory growth, against ``GET /healthz`` in the same run.

    .venv/bin/python -m bench.cutoff_stats [--models 100000] [--repeat 5]
"""

from __future__ import annotations

import argparse
import resource
import statistics
import tempfile
import time
import uuid

from fastapi.testclient import TestClient
from sqlalchemy import insert

from app.api.main import create_app
from app.db.models import Model, utcnow
from app.db.session import make_engine
from app.settings import Settings

# A stored cutoff record (core.cutoff.CutoffRecord.to_json) of a typical part.
RECORD = {"mode": "adaptive", "n": 185, "solver_calls": 2, "predicted": [180],
          "xi": 1e-10, "t": 0.01, "seed": 50, "n_min": 80, "n_max": 500, "margin": 10,
          "prediction": 180, "prediction_held": True, "features": [8.0, 0.3, 0.7, 0.5]}


def fill(database_url: str, count: int) -> None:
    now = utcnow()
    engine = make_engine(database_url)
    with engine.begin() as connection:
        for start in range(0, count, 20000):
            connection.execute(insert(Model), [
                {"id": uuid.uuid4(), "tenant": "default", "meta": {}, "status": "ready",
                 "file_name": f"part-{number}.stl", "file_size": 1, "file_sha256": "0" * 64,
                 "file_format": "stl", "n_points": 3000 + number % 997,
                 "cutoff": {**RECORD, "n": 150 + number % 71}, "created_at": now,
                 "updated_at": now}
                for number in range(start, min(count, start + 20000))
            ])
    engine.dispose()


def timed(client: TestClient, path: str, repeat: int) -> tuple[float, int]:
    """Median seconds of ``repeat`` GETs of ``path``, and the answer's bytes."""
    times, size = [], 0
    for _ in range(repeat):
        started = time.perf_counter()
        response = client.get(path)
        times.append(time.perf_counter() - started)
        response.raise_for_status()
        size = len(response.content)
    return statistics.median(times), size


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", type=int, default=100000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    folder = tempfile.mkdtemp()
    database_url = f"sqlite:///{folder}/bench.db"
    settings = Settings(database_url=database_url, data_dir=folder)
    with TestClient(create_app(settings, embedded_worker=False)) as client:
        fill(database_url, args.models)
        health, _ = timed(client, "/healthz", args.repeat)
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        seconds, size = timed(client, "/v1/stats/cutoff", args.repeat)
        grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
    print(f"GET /v1/stats/cutoff, {args.models} ready models, {args.repeat} requests: median "
          f"{seconds:.3f} s ({seconds / health:.0f}x /healthz's {health * 1000:.1f} ms), "
          f"{size / 1e6:.2f} MB an answer, peak memory +{grown / 1024:.0f} MB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
