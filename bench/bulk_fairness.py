"""How long a tenant's upload waits while a bulk load of that same tenant is queued.

Starts ``shapesearch serve`` (its in-process worker, one thread per core) on an empty SQLite
database with one tenant. Each round queues a load of ``--size`` jobs, then the tenant posts
one new part as usual and the script times how long it takes to become ready, and how many
of the load's jobs finished meanwhile; the round ends when the load has drained. The load is
``--load``:

* ``redescribe``: the operator re-describes the tenant's catalogue (``--size`` models,
  uploaded and described first) as ``shapesearch redescribe --all`` does
  (``app.ingest.redescribe.enqueue_models``);
* ``import``: the tenant posts ``--size`` point clouds at once marked ``background=true``, as
  ``shapesearch import`` sends them.

The baseline is the same upload on the idle service, measured in the same run. Prints
medians over ``--rounds``.

    nice -n 5 .venv/bin/python -m bench.bulk_fairness --load redescribe [--size 100] [--rounds 3]
    nice -n 5 .venv/bin/python -m bench.bulk_fairness --load import [--size 100] [--rounds 3]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
import uuid
from pathlib import Path

import httpx
from sqlalchemy import func, select
from sqlalchemy.orm import Session, sessionmaker

from app.db.models import Job
from app.db.session import make_engine, make_session_factory
from app.ingest.redescribe import enqueue_models
from bench.queue_fairness import keys, post, wait_ready
from tests.servers import running_server


def finished(sessions: sessionmaker[Session], job_ids: list[uuid.UUID]) -> int:
    """How many of ``job_ids`` are done or failed."""
    with sessions() as session:
        return int(session.scalar(
            select(func.count()).where(Job.id.in_(job_ids), Job.status.in_(("done", "failed")))
        ) or 0)


def drain(sessions: sessionmaker[Session]) -> None:
    """Wait until no job is queued or running."""
    while True:
        with sessions() as session:
            busy = session.scalar(
                select(func.count()).where(Job.status.in_(("queued", "running")))
            )
        if not busy:
            return
        time.sleep(0.5)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--load", choices=("redescribe", "import"), required=True)
    parser.add_argument("--size", type=int, default=100)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        url = f"sqlite:///{Path(folder) / 'db.sqlite'}"
        key = keys(url)["desk"]
        engine = make_engine(url)
        sessions = make_session_factory(engine)
        with running_server(Path(folder), worker=True) as (base, _pid), httpx.Client(
            base_url=base, timeout=60
        ) as client:
            if args.load == "redescribe":
                for i in range(args.size):
                    post(client, key, i)
                drain(sessions)
            idle = [wait_ready(client, key, post(client, key, 10_000 + i)["id"])
                    for i in range(args.rounds)]
            waits, overtaken, loads = [], [], []
            for round_number in range(args.rounds):
                if args.load == "redescribe":
                    load = enqueue_models(sessions, from_version=None, everything=True,
                                          current="")
                else:
                    load = [uuid.UUID(post(client, key, 1_000 * (round_number + 1) + i,
                                           background="true")["job"]["id"])
                            for i in range(args.size)]
                done_before = finished(sessions, load)
                upload = post(client, key, 20_000 + round_number)["id"]
                waits.append(wait_ready(client, key, upload))
                overtaken.append(finished(sessions, load) - done_before)
                loads.append(len(load))
                drain(sessions)
        engine.dispose()
    idle_median, wait_median = statistics.median(idle), statistics.median(waits)
    print(f"upload, idle service:                     median {idle_median:6.2f} s  "
          f"({', '.join(f'{s:.2f}' for s in idle)})")
    sizes = f"{min(loads)}" if min(loads) == max(loads) else f"{min(loads)}-{max(loads)}"
    print(f"upload behind {args.load} of {sizes} jobs: "
          f"median {wait_median:6.2f} s  ({', '.join(f'{s:.2f}' for s in waits)}), "
          f"{wait_median / idle_median:.1f}x idle")
    print(f"jobs of the load finished while it waited: median "
          f"{statistics.median(overtaken):.0f} ({', '.join(str(n) for n in overtaken)})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
