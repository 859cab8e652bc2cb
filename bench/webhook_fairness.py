"""How long one endpoint's event waits while another endpoint hangs with a backlog.

Two tenants on a new SQLite database, each with a webhook endpoint on 127.0.0.1: ``bulk``'s
endpoint hangs (it answers after ``--hang`` seconds, past the deliverer's ``--timeout``),
``desk``'s answers at once. Each round starts the delivery lanes as ``shapesearch serve`` and
each worker process do (``--lanes``, default ``SHAPESEARCH_WEBHOOK_LANES``), delivers one
event of ``desk`` (a warm-up), lets the lanes fall idle, then commits ``--backlog`` events for
``bulk`` and one for ``desk`` (the commit rings them) and waits until ``desk``'s event is
delivered: the time from the commit to its delivery, and how many of ``bulk``'s attempts
ended meanwhile. The baseline is ``desk``'s event on an idle outbox, measured in the same
run. Prints medians over ``--rounds``.

Then what the rule "one delivery in flight per endpoint" costs an idle lane: the time of a
claim that finds nothing because the one endpoint with due deliveries (``--look-backlog``
of them) has one in flight, against a claim on an empty outbox.

    nice -n 5 .venv/bin/python -m bench.webhook_fairness [--backlog 20] [--rounds 3]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session, sessionmaker

from app.db.migrate import upgrade
from app.db.models import Model, Webhook, WebhookAttempt, WebhookDelivery
from app.db.session import make_engine, make_session_factory
from app.settings import Settings
from app.webhooks import Deliverer, DeliveryLanes, record_model_event
from tests.plm_helpers import Receiver


@contextmanager
def hanging_endpoint(seconds: float) -> Iterator[str]:
    """The URL of an endpoint on 127.0.0.1 that answers 200 after ``seconds``."""

    class Handler(BaseHTTPRequestHandler):
        def do_POST(self) -> None:  # noqa: N802 (http.server's naming)
            time.sleep(seconds)
            self.send_response(200)
            self.send_header("content-length", "0")
            self.end_headers()

        def log_message(self, *args: Any) -> None:
            pass

    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    server.daemon_threads = True
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/hook"
    finally:
        server.shutdown()


def outbox(folder: Path, urls: dict[str, str]) -> tuple[sessionmaker[Session], dict[str, Any]]:
    """Sessions on a new database where each tenant of ``urls`` has a ready model and an
    endpoint at its URL; and each tenant's model id."""
    engine = make_engine(f"sqlite:///{folder / 'db.sqlite'}")
    upgrade(engine)
    sessions = make_session_factory(engine)
    models = {}
    with sessions.begin() as session:
        for tenant, url in urls.items():
            model = Model(tenant=tenant, meta={}, status="ready", file_name="part.stl",
                          file_size=1, file_sha256="0" * 64, file_format="stl")
            session.add_all([model, Webhook(tenant=tenant, url=url, events=["model.ready"],
                                            secret="whsec_" + "A" * 32)])
            session.flush()
            models[tenant] = model.id
    return sessions, models


def delivered(sessions: sessionmaker[Session], tenant: str, count: int = 1) -> bool:
    """Whether ``tenant``'s ``count`` events have all been delivered."""
    with sessions() as session:
        statuses = session.scalars(
            select(WebhookDelivery.status).join(Webhook).where(Webhook.tenant == tenant)
        ).all()
    return statuses == ["delivered"] * count


def wait_delivered(sessions: sessionmaker[Session], tenant: str, count: int) -> None:
    deadline = time.perf_counter() + 60
    while not delivered(sessions, tenant, count):
        if time.perf_counter() > deadline:
            raise RuntimeError(f"{tenant}'s events were not delivered within 60 s")
        time.sleep(0.002)


def attempts(sessions: sessionmaker[Session]) -> int:
    with sessions() as session:
        return int(session.scalar(select(func.count()).select_from(WebhookAttempt)) or 0)


def bench_deliverer(sessions: sessionmaker[Session], timeout: float) -> Deliverer:
    return Deliverer(sessions, worker_id="bench", allow_private=True, timeout=timeout,
                     max_attempts=5, backoff_base=60, backoff_cap=60, lease_seconds=60)


def desk_wait(
    folder: Path, urls: dict[str, str], backlog: int, timeout: float, lanes: int
) -> tuple[float, int]:
    """Seconds from ``desk``'s event to its delivery behind ``backlog`` events of ``bulk``,
    and the attempts that ended before it."""
    sessions, models = outbox(folder, urls)
    running = DeliveryLanes(bench_deliverer(sessions, timeout), lanes=lanes, poll_interval=1.0)
    running.start()
    try:
        with sessions.begin() as session:  # warm: one event through, then idle lanes
            record_model_event(session, models["desk"], "model.ready")
        wait_delivered(sessions, "desk", 1)
        time.sleep(0.5)
    except BaseException:
        running.stop()
        raise
    started = time.perf_counter()
    with sessions.begin() as session:
        for _ in range(backlog):
            record_model_event(session, models["bulk"], "model.ready")
        record_model_event(session, models["desk"], "model.ready")
    try:
        wait_delivered(sessions, "desk", 2)
        waited = time.perf_counter() - started
        return waited, attempts(sessions) - 2
    finally:
        running.stop()


def fruitless_look(folder: Path, urls: dict[str, str], backlog: int, repeat: int) -> float:
    """Median seconds of a claim that finds nothing: ``bulk`` has ``backlog`` due events
    and one of them in flight (0: an empty outbox)."""
    sessions, models = outbox(folder, urls)
    with sessions.begin() as session:
        for _ in range(backlog):
            record_model_event(session, models["bulk"], "model.ready")
    deliverer = bench_deliverer(sessions, 1.0)
    try:
        if backlog:
            assert deliverer.claim() is not None  # held: the others wait for it
        times = []
        for _ in range(repeat):
            started = time.perf_counter()
            assert deliverer.claim() is None
            times.append(time.perf_counter() - started)
    finally:
        deliverer.close()
    return statistics.median(times)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backlog", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--timeout", type=float, default=1.0)
    parser.add_argument("--hang", type=float, default=3.0)
    parser.add_argument("--lanes", type=int, default=Settings().webhook_lanes)
    parser.add_argument("--look-backlog", type=int, nargs="*", default=[1000, 10000])
    args = parser.parse_args()
    idle, waits, attempts_before = [], [], []
    with hanging_endpoint(args.hang) as hanging, Receiver() as receiver:
        urls = {"bulk": hanging, "desk": receiver.url}
        for _ in range(args.rounds):
            with tempfile.TemporaryDirectory() as folder:
                idle.append(desk_wait(Path(folder), urls, 0, args.timeout, args.lanes)[0])
            with tempfile.TemporaryDirectory() as folder:
                wait, made = desk_wait(Path(folder), urls, args.backlog, args.timeout, args.lanes)
                waits.append(wait)
                attempts_before.append(made)
    idle_median, wait_median = statistics.median(idle), statistics.median(waits)
    print(f"desk's event, idle outbox:      median {idle_median * 1000:8.1f} ms  "
          f"({', '.join(f'{s * 1000:.1f}' for s in idle)})")
    print(f"desk's event behind {args.backlog} events to an endpoint hanging past the "
          f"{args.timeout:g} s timeout: median {wait_median * 1000:8.1f} ms  "
          f"({', '.join(f'{s * 1000:.1f}' for s in waits)}), {wait_median / idle_median:.0f}x idle")
    print(f"attempts to the hanging endpoint ended before desk's delivery ({args.lanes} "
          f"lanes): median {statistics.median(attempts_before):.0f} "
          f"({', '.join(map(str, attempts_before))})")
    with tempfile.TemporaryDirectory() as folder:
        empty = fruitless_look(Path(folder), urls, 0, 50)
    print(f"an idle lane's look, empty outbox: median {empty * 1000:.2f} ms")
    for backlog in args.look_backlog:
        with tempfile.TemporaryDirectory() as folder:
            look = fruitless_look(Path(folder), urls, backlog, 20)
        print(f"an idle lane's look past {backlog} due events of an endpoint in flight: "
              f"median {look * 1000:.2f} ms, {look / empty:.1f}x the empty outbox's")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
