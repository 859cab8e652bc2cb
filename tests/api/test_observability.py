"""GET /metrics (Prometheus text), X-Request-ID, log lines (JSON, or text on a terminal) with
request and job ids, and keys that never reach a log."""

from __future__ import annotations

import errno
import io
import json
import logging
import os
import re
import threading
import time
from collections.abc import Callable, Iterator
from datetime import timedelta
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from prometheus_client import generate_latest
from prometheus_client.parser import text_string_to_metric_families
from pydantic import ValidationError
from sqlalchemy import create_engine, select, update
from sqlalchemy.orm import Session, sessionmaker
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import PlainTextResponse
from starlette.routing import Route

from app.api.main import create_app
from app.auth.keys import create_key
from app.db.models import Model, Webhook, WebhookDelivery, utcnow
from app.db.session import make_session_factory
from app.jobs.queue import JobQueue
from app.jobs.worker import Worker
from app.observability.logs import (
    QUEUED_LINES,
    LogFormat,
    Outage,
    RequestId,
    configure_logging,
    flush_logs,
    job_context,
)
from app.observability.metrics import (
    IndexCollector,
    QueueCollector,
    metrics_registry,
    observe_index,
)
from app.settings import Settings
from app.webhooks import Deliverer, record_model_event
from tests.conftest import PARTS, fake_describe, make_settings, wait_for_status

ROOT = Path(__file__).parents[2]
CUBE = (PARTS / "20mm-xyz-cube.stl").read_bytes()
LOOPBACK = ("127.0.0.1", 50000)


class Terminal(io.StringIO):
    """A stream that says it is a terminal, as stderr does in a shell."""

    def isatty(self) -> bool:
        return True


@pytest.fixture
def logs_to() -> Iterator[Callable[[io.StringIO, LogFormat], io.StringIO]]:
    """Configures logging into a stream for the test (restored after it)."""
    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level

    def configure(stream: io.StringIO, log_format: LogFormat) -> io.StringIO:
        # Written in the logging thread, so the test reads every line at once (the
        # background writer has a test of its own).
        configure_logging(stream=stream, log_format=log_format, background=False)
        return stream

    yield configure
    root.handlers[:] = handlers
    root.setLevel(level)
    logging.getLogger("uvicorn.access").disabled = False


@pytest.fixture
def json_logs(logs_to: Callable[[io.StringIO, LogFormat], io.StringIO]) -> io.StringIO:
    """JSON logging into the returned stream for the test: the default off a terminal."""
    return logs_to(io.StringIO(), "auto")


def samples(text: str) -> dict[tuple[str, tuple[tuple[str, str], ...]], float]:
    return {
        (sample.name, tuple(sorted(sample.labels.items()))): sample.value
        for family in text_string_to_metric_families(text)
        for sample in family.samples
    }


def log_lines(text: str) -> list[dict]:
    return [json.loads(line) for line in text.splitlines() if line.startswith("{")]


@pytest.mark.slow
def test_metrics_count_requests_jobs_describes_and_the_index(database_url: str) -> None:
    app = create_app(make_settings(database_url), embedded_worker=True, job_handler=fake_describe)
    with TestClient(app, client=LOOPBACK) as client:
        before = samples(client.get("/metrics").text)
        model = client.post(
            "/v1/models", files={"file": ("cube.stl", CUBE, "application/octet-stream")}
        ).json()
        wait_for_status(client, model["id"], ("ready",))
        client.get("/v1/models/not-a-model")
        response = client.get("/metrics")
    assert response.status_code == 200
    assert response.headers["content-type"].startswith("text/plain")
    after = samples(response.text)

    def grew(name: str, **labels: str) -> float:
        key = (name, tuple(sorted(labels.items())))
        return after.get(key, 0.0) - before.get(key, 0.0)

    assert grew(
        "shapesearch_http_requests_total", method="GET", route="/v1/models/{model_id}",
        status="404",
    ) == 1
    assert grew(
        "shapesearch_http_requests_total", method="POST", route="/v1/models", status="202"
    ) == 1
    assert grew(
        "shapesearch_http_request_duration_seconds_count", method="POST", route="/v1/models"
    ) == 1
    assert grew("shapesearch_describe_seconds_count", stage="total") == 1
    assert grew("shapesearch_solver_calls_total") == 2  # fake_describe: 2 solver calls
    assert grew("shapesearch_cutoff_n_count") == 1
    assert after[("shapesearch_jobs", (("status", "done"),))] == 1
    assert after[("shapesearch_queue_depth", ())] == 0
    assert after[("shapesearch_queue_oldest_age_seconds", ())] == 0
    partition = (("descriptor_version", "fake-1"), ("tenant", "default"))
    assert after[("shapesearch_index_partition_models", partition)] == 1
    assert after[("shapesearch_index_models", ())] == 1
    # One model: too few to keep neighbourhoods of, so none is missing.
    assert after[("shapesearch_index_neighbourhoods_kept_ratio", ())] == 1


@pytest.mark.slow
def test_metrics_answer_loopback_clients_only(database_url: str) -> None:
    app = create_app(make_settings(database_url))
    with TestClient(app, client=("203.0.113.9", 50000)) as client:
        refused = client.get("/metrics")
    assert refused.status_code == 403
    assert refused.json()["type"] == "urn:shapesearch:problem:forbidden"
    opened = create_app(make_settings(database_url, metrics_from_anywhere=True))
    with TestClient(opened, client=("203.0.113.9", 50000)) as client:
        assert client.get("/metrics").status_code == 200


@pytest.mark.slow
def test_request_ids_are_returned_and_on_every_log_line(
    database_url: str, json_logs: io.StringIO
) -> None:
    app = create_app(make_settings(database_url))
    secret = None
    with TestClient(app, raise_server_exceptions=False) as client:
        with make_session_factory(app.state.services.engine)() as session:
            secret = create_key(session, "acme")
            session.commit()
        given = client.get("/v1/models", headers={"X-Request-ID": "trace-42"})
        made = client.get(
            "/v1/models", headers={"Authorization": f"Bearer {secret}", "X-Request-ID": "a b"}
        )
    assert given.headers["x-request-id"] == "trace-42"
    assert made.headers["x-request-id"] != "a b" and len(made.headers["x-request-id"]) == 32
    output = json_logs.getvalue()
    assert secret not in output
    access = [line for line in log_lines(output) if line.get("logger") == "shapesearch.access"]
    assert {line["request_id"] for line in access} >= {"trace-42", made.headers["x-request-id"]}
    for line in access:
        assert line["message"] == "request" and line["route"] == "/v1/models"
        assert {"time", "level", "status", "duration_ms", "method"} <= set(line)


@pytest.mark.slow
def test_every_worker_line_carries_the_job_id(
    database_url: str, json_logs: io.StringIO
) -> None:
    def refuse(content: bytes, filename: str) -> dict:
        from core.errors import InvalidShapeError

        raise InvalidShapeError("degenerate", "all points on a line")

    app = create_app(make_settings(database_url), embedded_worker=True, job_handler=refuse)
    with TestClient(app) as client:
        model = client.post(
            "/v1/models", files={"file": ("cube.stl", CUBE, "application/octet-stream")}
        ).json()
        wait_for_status(client, model["id"], ("failed",))
    lines = log_lines(json_logs.getvalue())
    about_jobs = [
        line for line in lines
        if line["logger"] == "shapesearch.worker" and line["message"].startswith("job ")
    ]
    assert about_jobs, lines
    assert all("job_id" in line for line in about_jobs)
    assert all(line["message"].startswith(f"job {line['job_id']}") for line in about_jobs)


def test_the_grafana_dashboard_asks_for_metrics_that_exist(
    sessions: sessionmaker[Session],
) -> None:
    """Every series of docs/grafana-dashboard.json is one that /metrics or a worker exports
    (a renamed metric would leave a panel silently empty)."""
    dashboard = json.loads((ROOT / "docs" / "grafana-dashboard.json").read_text())
    expressions = [
        target["expr"] for panel in dashboard["panels"] for target in panel.get("targets", [])
    ]
    asked = {
        re.sub(r"_(bucket|count|sum|total)$", "", name)
        for expr in expressions
        for name in re.findall(r"\bshapesearch_[a-z_]+", expr)
    }
    observe_index(0, 1.0)  # the index gauges exist in API processes only
    registry = metrics_registry(QueueCollector(sessions), IndexCollector(sessions))
    exported = {family.name for family in registry.collect()}
    assert asked and asked <= exported, asked - exported
    assert len(dashboard["panels"]) == len({panel["id"] for panel in dashboard["panels"]})


@pytest.mark.slow
def test_the_webhook_outbox_is_exported_by_status_with_its_oldest_age(
    sessions: sessionmaker[Session],
) -> None:
    """A backlog behind an endpoint that is down shows as pending deliveries and as the age
    of the oldest one, on every process's scrape (read from the database)."""
    an_hour_ago = utcnow() - timedelta(hours=1)
    with sessions.begin() as session:
        model = Model(tenant="t", meta={}, status="ready", file_name="a.stl", file_size=1,
                      file_sha256="0" * 64, file_format="stl")
        session.add_all([model, Webhook(tenant="t", url="https://plm.example/hook",
                                        events=["model.ready"], secret="whsec_x")])
        session.flush()
        for _ in range(4):
            record_model_event(session, model.id, "model.ready")
        session.execute(update(WebhookDelivery).values(created_at=an_hour_ago))
    deliverer = Deliverer(sessions, worker_id="m", allow_private=False, timeout=5,
                          max_attempts=3, backoff_base=60, backoff_cap=60, lease_seconds=60)
    try:
        assert deliverer.claim() is not None  # one is being sent
    finally:
        deliverer.close()

    def exported() -> dict[tuple[str, tuple[tuple[str, str], ...]], float]:
        return samples(generate_latest(metrics_registry(QueueCollector(sessions))).decode())

    def by_status(scraped: dict[tuple[str, tuple[tuple[str, str], ...]], float]) -> list[float]:
        return [scraped[("shapesearch_webhook_deliveries", (("status", status),))]
                for status in ("pending", "sending", "delivered", "failed")]

    first = exported()
    assert by_status(first) == [3, 1, 0, 0]
    assert first[("shapesearch_webhook_oldest_undelivered_age_seconds", ())] >= 3600
    with sessions.begin() as session:  # settled: two delivered, one failed for good
        ids = session.scalars(select(WebhookDelivery.id).order_by(WebhookDelivery.turn)).all()
        session.execute(update(WebhookDelivery).where(WebhookDelivery.id.in_(ids[:2]))
                        .values(status="delivered"))
        session.execute(update(WebhookDelivery).where(WebhookDelivery.id == ids[2])
                        .values(status="failed"))
        session.execute(update(WebhookDelivery).where(WebhookDelivery.id == ids[3])
                        .values(created_at=utcnow()))
    second = exported()
    assert by_status(second) == [1, 0, 2, 1]
    assert second[("shapesearch_webhook_oldest_undelivered_age_seconds", ())] < 3600


def test_an_outage_is_logged_when_it_starts_once_a_minute_and_when_it_ends(
    caplog: pytest.LogCaptureFixture,
) -> None:
    now = [0.0]
    outage = Outage(logging.getLogger("test.outage"), "worker w: queue", clock=lambda: now[0])
    away = ConnectionRefusedError("connection refused")
    with caplog.at_level(logging.INFO, logger="test.outage"):
        for second in range(150):  # a failed poll every second for 150 s
            now[0] = float(second)
            outage.report(away)
        now[0] = 160.0
        outage.end()
        outage.end()  # no outage: nothing more
        outage.report(OSError(errno.ENOSPC, "No space left on device"))
    lines = [(r.levelname, r.exc_info is not None, r.getMessage()) for r in caplog.records]
    assert lines == [
        ("ERROR", True, "worker w: queue unavailable"),
        ("WARNING", False, "worker w: queue unavailable for 60 s: connection refused"),
        ("WARNING", False, "worker w: queue unavailable for 120 s: connection refused"),
        ("INFO", False, "worker w: queue available again after 160 s"),
        ("ERROR", False, "worker w: queue: storage full, nothing can be stored until space is "
                         "freed: [Errno 28] No space left on device"),
    ]


def test_a_worker_whose_database_is_away_logs_it_once_not_every_poll(
    tmp_path: Path, caplog: pytest.LogCaptureFixture,
) -> None:
    # No database can be opened there: every claim fails, 100 times a second.
    engine = create_engine(f"sqlite:///{tmp_path / 'missing-folder' / 'shapesearch.db'}")
    queue = JobQueue(make_session_factory(engine), lease_seconds=30, max_attempts=3,
                     backoff_base=1, backoff_cap=10)
    stop = threading.Event()
    worker = Worker(queue, fake_describe, worker_id="w", poll_interval=0.01, stop=stop)
    thread = threading.Thread(target=worker.run)
    with caplog.at_level(logging.INFO, logger="shapesearch.worker"):
        thread.start()
        time.sleep(0.5)
        stop.set()
        thread.join(10)
    failures = [r for r in caplog.records if "unavailable" in r.getMessage()]
    assert len(failures) == 1 and failures[0].exc_info is not None  # was one per poll
    assert "unable to open database" in str(failures[0].exc_info[1])
    engine.dispose()


def hello(request: Request) -> PlainTextResponse:
    logging.getLogger("test.app").info("hello %s", "there")
    return PlainTextResponse("hi")


# 2025-06-02 14:03:07,215 INFO     test.app: hello there request_id=trace-7
TEXT_LINE = re.compile(r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d{3} (?P<level>[A-Z]+) +"
                       r"(?P<logger>[\w.]+): (?P<rest>.*)$")


@pytest.mark.parametrize(
    ("stream", "log_format", "text"),
    [
        (Terminal, "auto", True),
        (io.StringIO, "auto", False),  # a file, a pipe, a container's log: JSON
        (Terminal, "json", False),
        (io.StringIO, "text", True),
    ],
)
def test_log_lines_are_text_on_a_terminal_or_when_asked_and_json_otherwise(
    logs_to: Callable[[io.StringIO, LogFormat], io.StringIO],
    stream: type[io.StringIO], log_format: LogFormat, text: bool,
) -> None:
    output = logs_to(stream(), log_format)
    app = RequestId(Starlette(routes=[Route("/hello", hello)]))
    with TestClient(app) as client:
        assert client.get("/hello", headers={"X-Request-ID": "trace-7"}).text == "hi"
    lines = output.getvalue().splitlines()
    if text:
        assert not any(line.startswith("{") for line in lines), lines
        parsed = [match.groupdict() for line in lines if (match := TEXT_LINE.match(line))]
        assert len(parsed) == len(lines), lines
        assert {"level": "INFO", "logger": "test.app",
                "rest": "hello there request_id=trace-7"} in parsed
        access = [line["rest"] for line in parsed if line["logger"] == "shapesearch.access"]
        assert len(access) == 1 and re.fullmatch(
            r"request method=GET route=/hello status=200 duration_ms=[\d.]+ "
            r"request_id=trace-7", access[0]), access
    else:
        records = [json.loads(line) for line in lines]
        assert {"logger": "test.app", "message": "hello there", "level": "INFO",
                "request_id": "trace-7"}.items() <= next(
            record for record in records if record["logger"] == "test.app").items()
        access = [record for record in records if record["logger"] == "shapesearch.access"]
        assert len(access) == 1 and access[0]["request_id"] == "trace-7"
        assert access[0]["status"] == 200 and access[0]["route"] == "/hello"


def test_text_lines_carry_the_job_id_and_a_traceback_below(
    logs_to: Callable[[io.StringIO, LogFormat], io.StringIO],
) -> None:
    output = logs_to(io.StringIO(), "text")
    log = logging.getLogger("test.worker")
    with job_context("4f1c"):
        log.info("job %s done", "4f1c", extra={"attempt": 2, "reason": "two words",
                                                "color_message": "uvicorn's, coloured"})
        try:
            raise ValueError("bad mesh")
        except ValueError:
            log.exception("job %s failed", "4f1c")
    lines = output.getvalue().splitlines()
    first = TEXT_LINE.match(lines[0])
    assert first is not None
    assert first["rest"] == "job 4f1c done attempt=2 reason='two words' job_id=4f1c"
    failed = TEXT_LINE.match(lines[1])
    assert failed is not None and failed["level"] == "ERROR"
    assert failed["rest"] == "job 4f1c failed job_id=4f1c"
    assert lines[2] == "Traceback (most recent call last):"
    assert lines[-1] == "ValueError: bad mesh"


def test_the_service_on_a_terminal_logs_readable_lines_with_the_request_id(
    database_url: str, logs_to: Callable[[io.StringIO, LogFormat], io.StringIO],
) -> None:
    output = logs_to(Terminal(), "auto")
    app = create_app(make_settings(database_url))
    with TestClient(app) as client:
        answer = client.get("/v1/models", headers={"X-Request-ID": "trace-42"})
    assert answer.headers["x-request-id"] == "trace-42"
    access = [match["rest"] for line in output.getvalue().splitlines()
              if (match := TEXT_LINE.match(line)) and match["logger"] == "shapesearch.access"]
    assert any(line.startswith("request method=GET route=/v1/models status=200 ")
               and line.endswith(" request_id=trace-42") for line in access), access


def test_the_log_format_is_a_setting(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("SHAPESEARCH_LOG_FORMAT", raising=False)
    assert Settings().log_format == "auto"
    monkeypatch.setenv("SHAPESEARCH_LOG_FORMAT", "text")
    assert Settings().log_format == "text"
    monkeypatch.setenv("SHAPESEARCH_LOG_FORMAT", "xml")
    with pytest.raises(ValidationError, match="log_format"):
        Settings()


class StuckSink(io.StringIO):
    """A log sink whose writes wait until ``release`` is set: a pipe nobody reads."""

    def __init__(self) -> None:
        super().__init__()
        self.release = threading.Event()

    def write(self, text: str) -> int:
        self.release.wait()
        return super().write(text)


def test_a_stuck_log_sink_never_holds_the_logging_thread(
        logs_to: Callable[[io.StringIO, LogFormat], io.StringIO]) -> None:
    sink = StuckSink()
    configure_logging(stream=sink, log_format="json")
    try:
        log = logging.getLogger("shapesearch.test")
        done = threading.Event()

        def flood() -> None:  # more lines than the queue holds
            for number in range(QUEUED_LINES + 500):
                log.info("line %d", number)
            done.set()

        threading.Thread(target=flood, daemon=True).start()
        # Every call returned although nothing could be written (a synchronous handler
        # would block on the first line for as long as the sink is stuck).
        assert done.wait(30)
        assert sink.getvalue() == ""
        sink.release.set()
        flush_logs()  # the queue drains once the sink moves again
        log.info("after")  # the first line with room: after the count of those lost
        flush_logs()
        lines = log_lines(sink.getvalue())
        messages = [line["message"] for line in lines]
        # The queue's lines in order, then the count of those dropped, then the next line.
        assert messages[0] == "line 0"
        assert any(m.endswith("log lines dropped: the log sink was slower than the lines "
                              "came") for m in messages)
        dropped = next(int(m.split()[0]) for m in messages if "dropped" in m)
        kept = [m for m in messages if m.startswith("line ")]
        assert len(kept) + dropped == QUEUED_LINES + 500
        assert messages[-1] == "after"
    finally:
        sink.release.set()
        configure_logging(stream=io.StringIO(), background=False)  # stops the writer


def test_a_forked_child_writes_its_own_lines(tmp_path: Path) -> None:
    """The writer thread does not survive a fork: a child writes directly, nothing lost."""
    out = tmp_path / "child.log"
    with out.open("w") as stream:
        configure_logging(stream=stream, log_format="json")
        try:
            pid = os.fork()
            if pid == 0:  # the child: log and leave at once, without atexit
                logging.getLogger("shapesearch.child").info("from the child")
                stream.flush()
                os._exit(0)
            os.waitpid(pid, 0)
        finally:
            configure_logging(stream=io.StringIO(), background=False)
    assert [line["message"] for line in log_lines(out.read_text())] == ["from the child"]
