"""How long one tenant's upload waits while another tenant's bulk import is queued.

Starts ``shapesearch serve`` (its in-process worker, one thread per core) on an empty SQLite
database with two API keys, tenants ``bulk`` and ``desk``. Each round, ``bulk`` posts
``--backlog`` point clouds at once (an import), then ``desk`` posts one and the script times
how long ``desk``'s model takes to become ready, and how many of ``bulk``'s jobs finished
meanwhile; the round ends when the backlog has drained. The baseline is the same ``desk``
upload on the idle service, measured in the same run. Prints medians over ``--rounds``.

    nice -n 5 .venv/bin/python -m bench.queue_fairness [--backlog 100] [--rounds 3]
"""

from __future__ import annotations

import argparse
import io
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np

from app.auth.keys import create_key
from app.db.migrate import upgrade
from app.db.session import make_engine, make_session_factory
from tests.servers import running_server
from tests.shapes import torus_points


def cloud(seed: int) -> bytes:
    """A torus of 4,000 points as an .xyz file; ``seed`` varies its proportions and sample."""
    rng = np.random.default_rng(seed)
    points = torus_points(4000, R=1.0, r=float(rng.uniform(0.2, 0.5)), seed=seed)
    text = io.StringIO()
    np.savetxt(text, points, fmt="%.6f")
    return text.getvalue().encode()


def keys(database_url: str) -> dict[str, str]:
    """A new API key for each tenant, in a database migrated to the current schema."""
    engine = make_engine(database_url)
    upgrade(engine)
    with make_session_factory(engine).begin() as session:
        made = {tenant: create_key(session, tenant) for tenant in ("bulk", "desk")}
    engine.dispose()
    return made


def post(client: httpx.Client, key: str, seed: int, **form: str) -> dict[str, Any]:
    """POST the point cloud of ``seed`` with the form fields ``form``; the new model (with
    its ``job``)."""
    response = client.post(
        "/v1/models", headers={"Authorization": f"Bearer {key}"},
        files={"file": (f"part-{seed}.xyz", cloud(seed))}, data=form,
    )
    response.raise_for_status()
    return dict(response.json())


def wait_ready(client: httpx.Client, key: str, model_id: str) -> float:
    """Seconds until ``model_id`` is ready (polled every 50 ms)."""
    started = time.perf_counter()
    while True:
        status = client.get(
            f"/v1/models/{model_id}", headers={"Authorization": f"Bearer {key}"}
        ).json()["status"]
        if status == "ready":
            return time.perf_counter() - started
        if status == "failed":
            raise RuntimeError(f"model {model_id} failed")
        time.sleep(0.05)


def jobs_done(client: httpx.Client, key: str) -> int:
    """How many of the key's tenant's jobs are done (paged through /v1/jobs)."""
    count, cursor = 0, None
    while True:
        params: dict[str, str | int] = {"status": "done", "limit": 100}
        if cursor:
            params["cursor"] = cursor
        page = client.get(
            "/v1/jobs", params=params, headers={"Authorization": f"Bearer {key}"}
        ).json()
        count += len(page["items"])
        cursor = page.get("next_cursor")
        if not cursor:
            return count


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backlog", type=int, default=100)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        made = keys(f"sqlite:///{Path(folder) / 'db.sqlite'}")
        with running_server(Path(folder), worker=True) as (base, _pid), httpx.Client(
            base_url=base, timeout=60
        ) as client:
            idle = [wait_ready(client, made["desk"], post(client, made["desk"], 10_000 + i)["id"])
                    for i in range(args.rounds)]
            waits, overtaken = [], []
            for round_number in range(args.rounds):
                first = round_number * args.backlog
                bulk_ids = [post(client, made["bulk"], first + i)["id"]
                            for i in range(args.backlog)]
                done_before = jobs_done(client, made["bulk"])
                desk_id = post(client, made["desk"], 20_000 + round_number)["id"]
                waits.append(wait_ready(client, made["desk"], desk_id))
                overtaken.append(jobs_done(client, made["bulk"]) - done_before)
                for model_id in bulk_ids:
                    wait_ready(client, made["bulk"], model_id)
    idle_median, wait_median = statistics.median(idle), statistics.median(waits)
    print(f"desk's upload, idle service:        median {idle_median:6.2f} s  "
          f"({', '.join(f'{s:.2f}' for s in idle)})")
    print(f"desk's upload behind {args.backlog} bulk jobs: median {wait_median:6.2f} s  "
          f"({', '.join(f'{s:.2f}' for s in waits)}), {wait_median / idle_median:.1f}x idle")
    print(f"bulk jobs finished while desk waited: median {statistics.median(overtaken):.0f} "
          f"({', '.join(str(n) for n in overtaken)})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
