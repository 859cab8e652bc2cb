"""Signed webhooks through HTTP with a real receiver on 127.0.0.1, on SQLite and PostgreSQL:
signatures verify with standardwebhooks, failures are retried with backoff and logged,
events survive a deliverer or worker that dies, and unsafe targets are refused."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from prometheus_client import REGISTRY
from sqlalchemy import select, update
from sqlalchemy.orm import Session, sessionmaker
from standardwebhooks.webhooks import Webhook as Verifier

from app.api.main import create_app
from app.db.doorbells import WEBHOOKS, Doorbell
from app.db.migrate import upgrade
from app.db.models import Model, Webhook, WebhookDelivery
from app.db.session import make_engine, make_session_factory, one_at_a_time
from app.jobs.lease import backoff_seconds
from app.jobs.queue import JobQueue
from app.settings import Settings
from app.webhooks import (
    Deliverer,
    DeliveryLanes,
    TargetRefused,
    check_target,
    pinned,
    record_model_event,
    recover,
)
from core.errors import InvalidShapeError
from tests.conftest import PARTS, fake_describe, make_settings, upload, wait_for_status
from tests.plm_helpers import ClientFactory, Receiver, started_clients

CUBE = PARTS / "20mm-xyz-cube.stl"
FAST_RETRIES = {"webhook_backoff_seconds": 0.05, "webhook_backoff_max_seconds": 0.2}


@pytest.fixture
def make_client(database_url: str) -> Iterator[ClientFactory]:
    with started_clients(database_url) as make:
        yield make


def refuse_teapots(content: bytes, filename: str) -> dict[str, Any]:
    if filename.startswith("teapot"):
        raise InvalidShapeError("degenerate", "This part is a teapot.")
    return fake_describe(content, filename)


def register(client: TestClient, url: str, events: list[str] | None = None, **extra: Any) -> Any:
    body = {"url": url, "events": events or ["model.ready", "model.failed", "model.deleted"]}
    response = client.post("/v1/webhooks", json={**body, **extra})
    assert response.status_code == 201, response.text
    return response.json()


def deliveries(client: TestClient, hook_id: str) -> list[dict[str, Any]]:
    response = client.get(f"/v1/webhooks/{hook_id}/deliveries")
    assert response.status_code == 200, response.text
    return response.json()["items"]


@pytest.mark.slow
def test_ready_failed_and_deleted_events_arrive_signed(make_client: ClientFactory) -> None:
    client = make_client(handler=refuse_teapots)
    with Receiver() as receiver:
        hook = register(client, receiver.url)
        assert hook["secret"].startswith("whsec_")
        assert [h["id"] for h in client.get("/v1/webhooks").json()["items"]] == [hook["id"]]
        assert "secret" not in client.get(f"/v1/webhooks/{hook['id']}").json()

        good = upload(client, CUBE).json()
        wait_for_status(client, good["id"])
        bad = upload(client, PARTS / "teapot.stl").json()
        assert wait_for_status(client, bad["id"])["status"] == "failed"
        assert client.delete(f"/v1/models/{good['id']}").status_code == 204
        requests = receiver.wait_for(3)

    verifier = Verifier(hook["secret"])
    events = {}
    for path, headers, body in requests:
        assert path == "/hook"
        event = verifier.verify(body, headers)  # raises unless the signature matches
        events[event["type"]] = event
    assert set(events) == {"model.ready", "model.failed", "model.deleted"}
    assert events["model.ready"]["data"]["model"]["id"] == good["id"]
    assert events["model.ready"]["data"]["model"]["status"] == "ready"
    assert events["model.ready"]["data"]["job"]["status"] == "done"
    assert events["model.failed"]["data"]["model"]["id"] == bad["id"]
    assert "teapot" in events["model.failed"]["data"]["model"]["error"]["detail"]
    assert events["model.deleted"]["data"]["model"]["id"] == good["id"]
    # A tampered body does not verify.
    _, headers, body = requests[0]
    with pytest.raises(Exception, match="signature"):
        verifier.verify(body.replace(b"model", b"modem"), headers)
    log = deliveries(client, hook["id"])
    assert len(log) == 3 and {d["status"] for d in log} == {"delivered"}


def attempts_counted(outcome: str) -> float:
    """The process's ``shapesearch_webhook_delivery_attempts_total`` for ``outcome``."""
    value = REGISTRY.get_sample_value(
        "shapesearch_webhook_delivery_attempts_total", {"outcome": outcome}
    )
    return value or 0.0


@pytest.mark.slow
def test_a_receiver_failing_twice_gets_the_event_three_times(make_client: ClientFactory) -> None:
    client = make_client(**FAST_RETRIES)
    retries_before, delivered_before = attempts_counted("retry"), attempts_counted("delivered")
    with Receiver(statuses=[500, 500]) as receiver:
        hook = register(client, receiver.url, events=["model.ready"])
        model = upload(client, CUBE).json()
        requests = receiver.wait_for(3)
        time.sleep(0.3)  # a fourth request would arrive within the backoff cap
        assert len(receiver.requests) == 3
    ids = {headers["webhook-id"] for _, headers, _ in requests}
    assert len(ids) == 1  # the same message each time: receivers can deduplicate
    deadline = time.monotonic() + 10
    while (log := deliveries(client, hook["id"]))[0]["status"] != "delivered":
        assert time.monotonic() < deadline, log
        time.sleep(0.05)
    (delivery,) = log
    assert delivery["id"] in ids and delivery["payload"]["data"]["model"]["id"] == model["id"]
    assert [a["status_code"] for a in delivery["attempts"]] == [500, 500, 200]
    assert [a["attempt"] for a in delivery["attempts"]] == [1, 2, 3]
    assert delivery["attempts"][0]["error"] == "HTTP 500"
    assert delivery["attempts"][2]["error"] is None
    # /metrics counts the attempts of this process's deliverer.
    assert attempts_counted("retry") - retries_before == 2
    assert attempts_counted("delivered") - delivered_before == 1


def wait_for_statuses(
    client: TestClient, hook_id: str, wanted: set[str], count: int
) -> list[dict[str, Any]]:
    deadline = time.monotonic() + 20
    while True:
        log = deliveries(client, hook_id)
        if len(log) == count and {d["status"] for d in log} <= wanted:
            return log
        assert time.monotonic() < deadline, log
        time.sleep(0.05)


@pytest.mark.slow
def test_failed_deliveries_are_sent_again_on_request(make_client: ClientFactory) -> None:
    """A receiver away longer than the retries lost its events for good (failed, never
    sent again). Recovering queues the failed ones again, oldest first, with their ids;
    one delivery can be sent again alone, a delivered one too."""
    client = make_client(**FAST_RETRIES, webhook_max_attempts=2)
    files = [PARTS / "20mm-xyz-cube.stl", PARTS / "cylinder.stl", PARTS / "angle_block.STL"]
    with Receiver(statuses=[503] * 6) as receiver:  # away: both attempts of all three fail
        hook = register(client, receiver.url, events=["model.ready"])
        for path in files:
            wait_for_status(client, upload(client, path).json()["id"])
        failed = wait_for_statuses(client, hook["id"], {"failed"}, 3)
        oldest_first = [d["id"] for d in reversed(failed)]
        assert len(receiver.requests) == 6

        since = failed[1]["created_at"]  # the two newest
        recovered = client.post(f"/v1/webhooks/{hook['id']}/recover", json={"since": since})
        assert recovered.status_code == 202 and recovered.json() == {"requeued": 2}
        wait_for_statuses(client, hook["id"], {"delivered", "failed"}, 3)
        assert client.post(f"/v1/webhooks/{hook['id']}/recover", json={}).json() == {
            "requeued": 1}  # every failed one left: the oldest
        log = wait_for_statuses(client, hook["id"], {"delivered"}, 3)
        resent = [headers["webhook-id"] for _, headers, _ in receiver.requests[6:]]
        assert resent == oldest_first[1:] + oldest_first[:1]  # in the order asked, by age
        oldest = next(d for d in log if d["id"] == oldest_first[0])
        assert [(a["attempt"], a["status_code"]) for a in oldest["attempts"]] == [
            (1, 503), (2, 503), (1, 200)]  # a new round, logged after the first

        again = client.post(f"/v1/webhooks/{hook['id']}/deliveries/{oldest['id']}/retry")
        assert again.status_code == 202 and again.json()["status"] == "pending"
        receiver.wait_for(10)
        assert receiver.requests[9][1]["webhook-id"] == oldest["id"]
    missing = client.post(f"/v1/webhooks/{hook['id']}/deliveries/{hook['id']}/retry")
    assert missing.status_code == 404
    assert missing.json()["type"] == "urn:shapesearch:problem:delivery-not-found"
    assert client.post(f"/v1/webhooks/{oldest['id']}/recover", json={}).status_code == 404
    bad = client.post(f"/v1/webhooks/{hook['id']}/recover", json={"since": "yesterday"})
    assert bad.status_code == 422


@pytest.mark.slow
def test_recovering_goes_in_batches_and_keeps_the_events_order(
    sessions: sessionmaker[Session],
) -> None:
    """Recovering 10^5 failed deliveries in one transaction held SQLite's write lock for
    6.6 s (bench/webhook_recover.py); now a batch at a time, each after the last one's last
    delivery, the turns still in the order the events were created."""
    models = two_endpoints(sessions, {"bulk": "https://example.com/bulk"}, backlog=5)
    with sessions.begin() as session:
        session.execute(update(WebhookDelivery).values(status="failed", attempts=20))
        hook = session.scalar(select(Webhook.id).where(Webhook.tenant == "bulk"))
    assert models and hook is not None
    assert recover(sessions, hook, batch=2) == 5  # 2, 2, then 1
    with sessions() as session:
        rows = session.execute(select(WebhookDelivery.status, WebhookDelivery.turn).order_by(
            WebhookDelivery.created_at, WebhookDelivery.id)).all()
    assert [status for status, _ in rows] == ["pending"] * 5
    turns = [turn for _, turn in rows]
    assert turns == sorted(turns) and len(set(turns)) == 5
    assert recover(sessions, hook) == 0  # nothing failed is left


def test_the_default_retries_span_the_documented_ten_hours() -> None:
    """The README and the setting say a receiver away overnight misses nothing: the
    delays between the default attempts add up to about 10.4 hours (8 attempts used to
    span 10.6 minutes)."""
    settings = Settings(database_url="sqlite://")
    delays = [backoff_seconds(attempt, settings.webhook_backoff_seconds,
                              settings.webhook_backoff_max_seconds)
              for attempt in range(1, settings.webhook_max_attempts)]
    assert round(sum(delays) / 3600, 1) == 10.4


@pytest.mark.slow
def test_an_event_outlives_the_worker_that_completed_the_job(
    make_client: ClientFactory, database_url: str
) -> None:
    # An API process without workers takes the upload; a "worker" completes the job and
    # dies before delivering (no deliverer runs); the event is in the outbox all the same.
    api = make_client(embedded_worker=False)
    with Receiver() as receiver:
        register(api, receiver.url, events=["model.ready"])
        model = upload(api, CUBE).json()
        sessions = make_session_factory(make_engine(database_url))
        queue = JobQueue(sessions, lease_seconds=30, max_attempts=3)
        claim = queue.claim("doomed-worker")
        assert claim is not None and str(claim.model_id) == model["id"]
        assert queue.complete(claim, fake_describe(CUBE.read_bytes(), CUBE.name))
        time.sleep(0.3)
        assert receiver.requests == []

        # A deliverer claims it and dies mid-delivery: its lease runs out ...
        dying = Deliverer(sessions, worker_id="dying", allow_private=True, timeout=0.1,
                          max_attempts=5, backoff_base=0.05, backoff_cap=0.1,
                          lease_seconds=0.1)
        assert dying.claim() is not None
        dying.close()
        # ... and another worker process delivers it.
        make_client()
        (request,) = receiver.wait_for(1)
        event = json.loads(request[2])
        assert event["type"] == "model.ready" and event["data"]["model"]["id"] == model["id"]


def two_endpoints(
    sessions: sessionmaker[Session], urls: dict[str, str], backlog: int
) -> dict[str, Any]:
    """Each tenant of ``urls`` with a ready model and an endpoint at its URL, and
    ``backlog`` events queued for ``bulk``; the models' ids by tenant."""
    models = {}
    with sessions.begin() as session:
        for tenant, url in urls.items():
            model = Model(tenant=tenant, meta={}, status="ready", file_name="a.stl",
                          file_size=1, file_sha256="0" * 64, file_format="stl")
            session.add_all([model, Webhook(tenant=tenant, url=url, events=["model.ready"],
                                            secret="whsec_" + "A" * 32)])
            session.flush()
            models[tenant] = model.id
        for _ in range(backlog):
            record_model_event(session, models["bulk"], "model.ready")
    return models


def local_deliverer(sessions: sessionmaker[Session], timeout: float) -> Deliverer:
    """A deliverer to endpoints on 127.0.0.1 that retries nothing during a test."""
    return Deliverer(sessions, worker_id="test", allow_private=True, timeout=timeout,
                     max_attempts=3, backoff_base=60, backoff_cap=60,
                     lease_seconds=2 * timeout)


@pytest.mark.slow
def test_an_endpoint_has_one_delivery_in_flight_and_others_take_turns_with_its_backlog(
    sessions: sessionmaker[Session],
) -> None:
    """Claimed oldest first, the other endpoint's event waited for the whole backlog: with an
    endpoint that hangs for its timeout, that was a timeout per event of the backlog. Now an
    endpoint's backlog takes one turn a round, and one of its deliveries is out at a time."""
    with Receiver() as bulk, Receiver() as desk:
        urls = {"bulk": bulk.url, "desk": desk.url}
        models = two_endpoints(sessions, urls, backlog=4)
        deliverer = local_deliverer(sessions, timeout=30)
        try:
            first = deliverer.claim()  # held under its lease, as while it is being sent
            assert first is not None and first.url == urls["bulk"]
            assert deliverer.claim() is None  # bulk's next three wait for it
            with sessions.begin() as session:
                record_model_event(session, models["desk"], "model.ready")
            beside = deliverer.claim()  # desk's event goes out beside bulk's
            assert beside is not None and beside.url == urls["desk"]
            deliverer.deliver(first)
            order = []
            while (claimed := deliverer.claim()) is not None:
                order.append(claimed.url)
                deliverer.deliver(claimed)
            deliverer.deliver(beside)
        finally:
            deliverer.close()
        assert order == [urls["bulk"]] * 3
        assert len(bulk.requests) == 4 and len(desk.requests) == 1


@pytest.mark.slow
def test_an_endpoint_that_hangs_holds_one_lane_while_the_others_deliver(
    sessions: sessionmaker[Session],
) -> None:
    """With one lane, each event of another endpoint waited out one of the hanging
    endpoint's timeouts; now it is sent while the hanging endpoint still holds its first."""
    let_go = threading.Event()
    with Receiver(hold=let_go) as bulk, Receiver() as desk:
        models = two_endpoints(sessions, {"bulk": bulk.url, "desk": desk.url}, backlog=3)
        lanes = DeliveryLanes(local_deliverer(sessions, timeout=60), lanes=3,
                              poll_interval=0.05)
        lanes.start()
        try:
            (held,) = bulk.wait_for(1)
            with sessions.begin() as session:
                for _ in range(2):
                    record_model_event(session, models["desk"], "model.ready")
            assert len(desk.wait_for(2)) == 2
            assert len(bulk.requests) == 1  # its other two wait for the one it holds
            let_go.set()
            delivered = bulk.wait_for(3)
        finally:
            let_go.set()
            lanes.stop()
    with sessions() as session:
        queued = session.scalars(
            select(WebhookDelivery.id).join(Webhook).where(Webhook.tenant == "bulk")
            .order_by(WebhookDelivery.turn)
        ).all()
    sent = [headers["webhook-id"] for _path, headers, _body in delivered]
    assert sent == [str(delivery) for delivery in queued]  # one at a time, in order
    assert held == delivered[0]


@pytest.mark.slow
def test_idle_lanes_look_for_work_as_often_as_one_lane(sessions: sessionmaker[Session]) -> None:
    """Each idle lane used to look on its own timer: four lanes, four times the polling of
    the database. Now a lane's timeout looks only if no lane has looked for a whole
    interval (a ring still wakes every idle lane: test_doorbells.py)."""
    looks: list[float] = []

    class Counting(Deliverer):
        def claim(self) -> Any:
            looks.append(time.monotonic())
            return super().claim()

    interval = 0.1
    deliverer = Counting(sessions, worker_id="idle", allow_private=True, timeout=5,
                         max_attempts=3, backoff_base=60, backoff_cap=60, lease_seconds=10)
    lanes = DeliveryLanes(deliverer, lanes=4, poll_interval=interval,
                          doorbell=Doorbell(WEBHOOKS.channel))
    lanes.start()
    try:
        time.sleep(0.3)  # the first looks are behind us
        started, before = time.monotonic(), len(looks)
        time.sleep(2.0)
        idle_looks = len(looks) - before
        elapsed = time.monotonic() - started
    finally:
        lanes.stop()
    # One lane's polling is elapsed / interval looks (fewer on a slow machine); four lanes
    # each on its own timer made four times that.
    assert 0 < idle_looks <= 1.5 * elapsed / interval


@pytest.mark.slow
def test_claims_are_not_refused_while_another_connection_writes(
    sessions: sessionmaker[Session],
) -> None:
    """A claim read the outbox and then wrote its claim. On SQLite a commit between the two
    made the write fail at once with "database is locked" (1,305 of 1,356 claims beside a
    loop of inserts), which the lanes took for an outage; now every claim takes the write
    lock first. Each claim's lease lapses at once, so that every look finds a delivery and
    writes."""
    with sessions.begin() as session:
        model = Model(tenant="t", meta={}, status="ready", file_name="a.stl", file_size=1,
                      file_sha256="0" * 64, file_format="stl")
        session.add(model)
        session.add_all(Webhook(tenant="t", url=f"http://127.0.0.1:9/{n}", events=["model.ready"],
                                secret="whsec_" + "A" * 32) for n in range(20))
        session.flush()
        record_model_event(session, model.id, "model.ready")
    deliverer = Deliverer(sessions, worker_id="busy", allow_private=True, timeout=0.0005,
                          max_attempts=3, backoff_base=60, backoff_cap=60, lease_seconds=0.001)
    stop = threading.Event()
    writes: list[int] = []

    def write() -> None:
        while not stop.is_set():
            with sessions.begin() as session:
                session.add(Model(tenant="w", meta={}, status="queued", file_name="b.stl",
                                  file_size=1, file_sha256="0" * 64, file_format="stl"))
            writes.append(1)

    writer = threading.Thread(target=write)
    writer.start()
    claimed, refused = 0, 0
    try:
        deadline = time.monotonic() + 1.5
        while time.monotonic() < deadline:
            try:
                claimed += deliverer.claim() is not None
            except Exception:
                refused += 1
            time.sleep(0.002)  # a lane's pace, not a loop that keeps the writer waiting
    finally:
        stop.set()
        writer.join()
        deliverer.close()
    assert len(writes) > 10 and claimed > 10  # both went on side by side
    assert refused == 0


@pytest.mark.slow
def test_claims_of_two_processes_go_one_after_another(database_url: str) -> None:
    """The transaction that a claim begins with ``one_at_a_time`` holds the next one
    (another engine, as another process has) until it ends: each claim reads the one
    before it committed, on PostgreSQL too, where two claims used to read side by side."""
    first_engine, second_engine = make_engine(database_url), make_engine(database_url)
    upgrade(first_engine)
    first, second = make_session_factory(first_engine), make_session_factory(second_engine)
    entered = threading.Event()
    waited: list[float] = []

    def later() -> None:
        entered.wait()
        started = time.monotonic()
        with second.begin() as session:
            one_at_a_time(session, "shapesearch.webhook-claims")
            waited.append(time.monotonic() - started)

    thread = threading.Thread(target=later)
    thread.start()
    try:
        with first.begin() as session:
            one_at_a_time(session, "shapesearch.webhook-claims")
            entered.set()
            time.sleep(0.5)  # the other transaction is waiting meanwhile
        thread.join(10)
        assert waited and waited[0] >= 0.4
        with second.begin() as session:  # another name does not wait
            started = time.monotonic()
            one_at_a_time(session, "another")
            assert time.monotonic() - started < 0.3
    finally:
        first_engine.dispose()
        second_engine.dispose()


def test_an_idle_look_does_not_wait_for_another_claim(database_url: str) -> None:
    """A look that finds nothing takes no lock: an idle lane neither waits for a claim of
    another process nor, on SQLite, holds up the writers."""
    holder_engine, engine = make_engine(database_url), make_engine(database_url)
    upgrade(holder_engine)
    deliverer = Deliverer(make_session_factory(engine), worker_id="idle", allow_private=True,
                          timeout=5, max_attempts=3, backoff_base=60, backoff_cap=60,
                          lease_seconds=10)
    looked: list[object] = []
    try:
        with make_session_factory(holder_engine).begin() as session:
            one_at_a_time(session, "shapesearch.webhook-claims")  # another process's claim
            look = threading.Thread(target=lambda: looked.append(deliverer.claim()))
            look.start()
            look.join(3)
            assert not look.is_alive() and looked == [None]
    finally:
        deliverer.close()
        holder_engine.dispose()
        engine.dispose()


@pytest.mark.slow
def test_unsafe_targets_are_refused_and_redirects_not_followed(
    make_client: ClientFactory, database_url: str
) -> None:
    strict = TestClient(create_app(make_settings(database_url, workers=0)))
    with strict:
        for url in ("http://127.0.0.1:9/hook", "http://[::1]/x", "http://10.1.2.3/",
                    "http://169.254.169.254/latest", "ftp://example.com/x", "file:///etc/passwd",
                    "http://user:pw@example.com/"):
            response = strict.post("/v1/webhooks", json={"url": url, "events": ["model.ready"]})
            assert response.status_code == 422, (url, response.text)
            assert response.headers["content-type"].startswith("application/problem+json")
        bad_events = strict.post("/v1/webhooks", json={"url": "https://example.com",
                                                       "events": ["model.exploded"]})
        assert bad_events.status_code == 422
        bad_secret = strict.post("/v1/webhooks", json={"url": "http://127.0.0.1/",
                                                       "events": ["model.ready"], "secret": "x"})
        assert bad_secret.status_code == 422

    client = make_client(webhook_max_attempts=1)
    with Receiver(redirect_to="/elsewhere") as receiver:
        hook = register(client, receiver.url, events=["model.ready"])
        upload(client, CUBE)
        receiver.wait_for(1)
        deadline = time.monotonic() + 10
        while (log := deliveries(client, hook["id"]))[0]["status"] != "failed":
            assert time.monotonic() < deadline, log
            time.sleep(0.05)
        assert [path for path, _, _ in receiver.requests] == ["/hook"]  # not followed
        assert log[0]["attempts"][0]["status_code"] == 307
    assert client.delete(f"/v1/webhooks/{hook['id']}").status_code == 204
    assert client.get(f"/v1/webhooks/{hook['id']}").status_code == 404
    assert client.delete(f"/v1/webhooks/{hook['id']}").status_code == 404


def test_a_checked_address_is_pinned_keeping_host_and_tls_name() -> None:
    assert pinned("https://hooks.example.com/x?a=1", "93.184.216.34") == (
        "https://93.184.216.34/x?a=1",
        {"host": "hooks.example.com"},
        {"sni_hostname": "hooks.example.com"},
    )
    assert pinned("http://hooks.example.com:8080/x", "2606:2800:220:1::1") == (
        "http://[2606:2800:220:1::1]:8080/x",
        {"host": "hooks.example.com:8080"},
        {},
    )
    assert pinned("http://127.0.0.1:9/x", None) == ("http://127.0.0.1:9/x", {}, {})
    assert check_target("http://127.0.0.1:9/x", allow_private=True) is None
    assert check_target("http://93.184.216.34/x", allow_private=False) == "93.184.216.34"
    with pytest.raises(TargetRefused, match="non-public"):
        check_target("http://192.168.1.20/x", allow_private=False)


@pytest.mark.parametrize(
    "url",
    [
        "http://[64:ff9b::7f00:1]/",  # NAT64 of 127.0.0.1
        "http://[64:ff9b:1::a00:1]/",  # local-use NAT64 of 10.0.0.1
        "http://[2002:7f00:1::]/",  # 6to4 of 127.0.0.1
        "http://[::ffff:127.0.0.1]/",  # IPv4-mapped
        "http://[::127.0.0.1]/",  # IPv4-compatible
        "http://[2001:0:4136:e378:8000:63bf:3fff:fdd2]/",  # Teredo
    ],
)
def test_ipv6_forms_of_private_ipv4_addresses_are_judged_by_that_address(url: str) -> None:
    with pytest.raises(TargetRefused, match="non-public"):
        check_target(url, allow_private=False)


def test_a_nat64_form_of_a_public_address_is_allowed() -> None:
    assert check_target("http://[64:ff9b::808:808]/", allow_private=False) == "64:ff9b::808:808"
