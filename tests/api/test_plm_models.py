"""Jobs, upsert by external id, revisions, Idempotency-Key, originals, re-describe and stats,
through HTTP on SQLite and PostgreSQL with the fake describer."""

from __future__ import annotations

import time
from collections.abc import Iterator
from datetime import timedelta
from typing import Any

import pytest
from fastapi.testclient import TestClient

from app.api import idempotency
from app.db.models import utcnow
from app.db.session import make_engine, make_session_factory
from app.jobs.queue import JobQueue
from tests.conftest import PARTS, upload, wait_for_status
from tests.plm_helpers import ClientFactory, GatedDescriber, box_stl, started_clients

CUBE = PARTS / "20mm-xyz-cube.stl"


@pytest.fixture
def make_client(database_url: str) -> Iterator[ClientFactory]:
    with started_clients(database_url) as make:
        yield make


@pytest.fixture
def client(make_client: ClientFactory) -> TestClient:
    return make_client()


def wait_for_job(client: TestClient, job_id: str, timeout: float = 30.0) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while True:
        job = client.get(f"/v1/jobs/{job_id}").json()
        if job["status"] in ("done", "failed"):
            return job
        assert time.monotonic() < deadline, job
        time.sleep(0.05)


def put(client: TestClient, external_id: str, content: bytes, **form: str) -> Any:
    return client.put(
        f"/v1/models/by-external-id/{external_id}",
        files={"file": ("part.stl", content, "application/octet-stream")},
        data=form,
    )


# --- jobs -------------------------------------------------------------------------------


@pytest.mark.slow
def test_the_202_body_and_the_model_carry_the_job(client: TestClient) -> None:
    accepted = upload(client, CUBE).json()
    job = accepted["job"]
    assert set(job) == {"id", "status", "attempts", "created_at", "updated_at"}
    assert job["status"] in ("queued", "running", "done") and job["attempts"] in (0, 1)
    ready = wait_for_status(client, accepted["id"])
    assert ready["job"]["id"] == job["id"]
    assert ready["job"]["status"] == "done" and ready["job"]["attempts"] == 1
    body = client.get(f"/v1/jobs/{job['id']}").json()
    assert body["model_id"] == accepted["id"] and body["status"] == "done"
    listed = client.get("/v1/models").json()["items"]
    assert listed[0]["job"]["id"] == job["id"]


@pytest.mark.slow
def test_jobs_are_listed_with_filter_and_cursor(client: TestClient) -> None:
    ids = [upload(client, CUBE, filename=f"c{i}.stl").json()["job"]["id"] for i in range(5)]
    for job_id in ids:
        wait_for_job(client, job_id)
    seen: list[str] = []
    cursor = None
    while True:
        params: dict[str, Any] = {"limit": 2}
        if cursor:
            params["cursor"] = cursor
        page = client.get("/v1/jobs", params=params).json()
        assert len(page["items"]) <= 2
        seen += [job["id"] for job in page["items"]]
        cursor = page["next_cursor"]
        if cursor is None:
            break
    assert seen == ids[::-1]  # newest first, each once
    done = client.get("/v1/jobs", params={"status": "done"}).json()["items"]
    assert [job["id"] for job in done] == ids[::-1]
    assert client.get("/v1/jobs", params={"status": "queued"}).json()["items"] == []
    assert client.get("/v1/jobs", params={"cursor": "%%%"}).status_code == 422


@pytest.mark.slow
def test_uploads_sent_as_background_take_turns_with_the_tenants_other_uploads(
    make_client: ClientFactory, database_url: str,
) -> None:
    """A bulk load of one tenant (background=true, as ``shapesearch import`` sends it) and
    that tenant's other uploads take turns: the upload after the load is claimed second,
    not after the whole load."""
    client = make_client(embedded_worker=False)
    load = [put(client, f"bulk-{i}", box_stl(1 + i / 10), background="true").json()["job"]["id"]
            for i in range(4)]
    load.append(upload(client, CUBE, background="true").json()["job"]["id"])
    desk = upload(client, CUBE, filename="desk.stl").json()["job"]["id"]
    jobs = {job["id"]: job["background"] for job in client.get("/v1/jobs").json()["items"]}
    assert jobs == {**dict.fromkeys(load, True), desk: False}
    engine = make_engine(database_url)
    try:
        queue = JobQueue(make_session_factory(engine), lease_seconds=30, max_attempts=3,
                         backoff_base=1, backoff_cap=1)
        order = []
        while (claim := queue.claim("w")) is not None:
            order.append(str(claim.job_id))
            assert queue.fail(claim, {"detail": "only the order is asked"})
    finally:
        engine.dispose()
    assert order == [load[0], desk, *load[1:]]  # oldest first, desk would have come last


# --- idempotency ----------------------------------------------------------------------


@pytest.mark.slow
def test_idempotency_key_replays_the_first_answer(client: TestClient) -> None:
    key = {"Idempotency-Key": "sync-42"}
    first = upload(client, CUBE, headers=key, external_id="p-1", name="Cube")
    assert first.status_code == 202, first.text
    again = upload(client, CUBE, headers=key, external_id="p-1", name="Cube")
    assert again.status_code == 202, again.text
    assert again.json()["id"] == first.json()["id"]
    assert again.json()["job"]["id"] == first.json()["job"]["id"]
    assert again.headers["location"] == f"/v1/models/{first.json()['id']}"
    assert len(client.get("/v1/models").json()["items"]) == 1
    other = upload(client, CUBE, headers=key, external_id="p-1", name="Other name")
    assert other.status_code == 422
    assert other.json()["type"].endswith("idempotency-key-reused")
    bulk = upload(client, CUBE, headers=key, external_id="p-1", name="Cube", background="true")
    assert bulk.status_code == 422  # another request: part of a bulk load
    fresh = upload(client, CUBE, headers={"Idempotency-Key": "sync-43"}, name="Cube")
    assert fresh.status_code == 202 and fresh.json()["id"] != first.json()["id"]


@pytest.mark.slow
def test_idempotency_keys_expire(make_client: ClientFactory,
                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """After ``idempotency_ttl_seconds`` a key is forgotten: the same key makes a new model,
    and storing it deletes the tenant's expired keys."""
    client = make_client(idempotency_ttl_seconds=60)
    key = {"Idempotency-Key": "sync-7"}
    first = upload(client, CUBE, headers=key, name="Cube")
    assert upload(client, CUBE, headers=key, name="Cube").json()["id"] == first.json()["id"]
    old = upload(client, CUBE, headers={"Idempotency-Key": "sync-8"}, name="Cube")
    # A minute later by the clock the expiry reads, not by sleeping: a short TTL and a sleep
    # made a slow upload on a busy machine outlive the TTL before its replay was asked.
    monkeypatch.setattr(idempotency, "utcnow", lambda: utcnow() + timedelta(seconds=61))
    later = upload(client, CUBE, headers=key, name="Cube")
    assert later.status_code == 202 and later.json()["id"] != first.json()["id"]
    assert "idempotent-replayed" not in later.headers
    # sync-8 has expired as well: the same key with another body is a new request.
    again = upload(client, CUBE, headers={"Idempotency-Key": "sync-8"}, name="Other name")
    assert again.status_code == 202 and again.json()["id"] != old.json()["id"]


# --- upsert and revisions -------------------------------------------------------------


@pytest.mark.slow
def test_upsert_creates_then_changes_only_metadata_for_the_same_file(
    client: TestClient,
) -> None:
    created = put(client, "PN-1", box_stl(1.0), name="Bracket", metadata='{"rev": "A"}')
    assert created.status_code == 201, created.text
    model = created.json()
    assert model["external_id"] == "PN-1"
    assert model["job"]["status"] in ("queued", "running", "done")
    wait_for_status(client, model["id"])
    same = put(client, "PN-1", box_stl(1.0), name="Bracket v2", metadata='{"rev": "B"}')
    assert same.status_code == 200, same.text
    body = same.json()
    assert body["id"] == model["id"] and body["name"] == "Bracket v2"
    assert body["metadata"] == {"rev": "B"} and body["job"]["id"] == model["job"]["id"]
    assert len(client.get("/v1/jobs").json()["items"]) == 1
    revisions = client.get(f"/v1/models/{model['id']}/revisions").json()["items"]
    assert [(r["number"], r["status"]) for r in revisions] == [(1, "current")]


@pytest.mark.slow
def test_a_new_file_is_a_new_revision_and_the_old_descriptor_serves_meanwhile(
    make_client: ClientFactory,
) -> None:
    marker = b"solid gated"
    gated = GatedDescriber(marker)
    client = make_client(handler=gated)
    neighbour = put(client, "N", box_stl(3.0)).json()
    first = put(client, "PN-2", box_stl(1.0)).json()
    wait_for_status(client, neighbour["id"])
    ready = wait_for_status(client, first["id"])
    old_sha = ready["file"]["sha256"]

    def similar_score() -> float:
        results = client.get(f"/v1/models/{neighbour['id']}/similar").json()["results"]
        return next(r["score"] for r in results if r["model"]["id"] == first["id"])

    old_score = similar_score()
    new_file = marker + box_stl(2.0)[len(marker):]  # STL header text is free
    changed = put(client, "PN-2", new_file)
    assert changed.status_code == 202, changed.text
    assert changed.json()["id"] == first["id"]
    new_job = changed.json()["job"]
    assert new_job["id"] != first["job"]["id"]
    assert gated.entered.wait(30)
    # While the new revision is being described the model still serves the old one.
    during = client.get(f"/v1/models/{first['id']}").json()
    assert during["status"] == "ready" and during["file"]["sha256"] == old_sha
    assert similar_score() == pytest.approx(old_score)
    assert client.get(f"/v1/models/{first['id']}/file").content == box_stl(1.0)
    revisions = client.get(f"/v1/models/{first['id']}/revisions").json()["items"]
    assert [r["status"] for r in revisions] == ["pending", "current"]

    gated.release()
    assert wait_for_job(client, new_job["id"])["status"] == "done"
    after = client.get(f"/v1/models/{first['id']}").json()
    assert after["status"] == "ready" and after["file"]["sha256"] != old_sha
    assert after["file"]["size"] == len(new_file)
    assert client.get(f"/v1/models/{first['id']}/file").content == new_file
    assert similar_score() != pytest.approx(old_score)
    revisions = client.get(f"/v1/models/{first['id']}/revisions").json()["items"]
    assert [(r["number"], r["status"]) for r in revisions] == [(2, "current"), (1, "superseded")]


# --- originals, re-describe, stats ----------------------------------------------------


def test_the_original_file_comes_back_with_its_name(client: TestClient) -> None:
    model = upload(client, CUBE).json()
    response = client.get(f"/v1/models/{model['id']}/file")
    assert response.status_code == 200
    assert response.content == CUBE.read_bytes()
    assert CUBE.name in response.headers["content-disposition"]
    assert response.headers["content-type"] == "model/stl"
    assert client.get("/v1/models/00000000-0000-0000-0000-000000000000/file").status_code == 404


@pytest.mark.slow
def test_redescribe_makes_a_new_job_and_stats_count_versions(client: TestClient) -> None:
    model = upload(client, CUBE).json()
    wait_for_status(client, model["id"])
    response = client.post(f"/v1/models/{model['id']}/redescribe")
    assert response.status_code == 202, response.text
    job = response.json()
    assert job["model_id"] == model["id"] and job["id"] != model["job"]["id"]
    assert job["background"] is False  # one re-describe: the tenant's own turn
    assert response.headers["location"] == f"/v1/jobs/{job['id']}"
    assert wait_for_job(client, job["id"])["status"] == "done"
    assert client.get(f"/v1/models/{model['id']}").json()["job"]["id"] == job["id"]
    # One of many re-describes sent together takes the bulk load's turns (app.jobs.turns).
    bulk = client.post(f"/v1/models/{model['id']}/redescribe", params={"background": "true"})
    assert bulk.status_code == 202 and bulk.json()["background"] is True
    assert wait_for_job(client, bulk.json()["id"])["background"] is True
    stats = client.get("/v1/stats").json()
    assert stats["models"] == 1 and stats["by_status"] == {"ready": 1}
    assert stats["by_descriptor_version"] == {"fake-1": 1}
    assert stats["jobs_by_status"] == {"done": 3}
    assert stats["current_descriptor_version"] != "fake-1"
    assert client.post("/v1/models/nope/redescribe").status_code == 404


def test_jobs_webhooks_and_stats_are_per_tenant(
    make_client: ClientFactory, database_url: str
) -> None:
    from app.auth.keys import create_key
    from app.db.session import make_engine, make_session_factory

    client = make_client()  # applies the migrations
    sessions = make_session_factory(make_engine(database_url))
    with sessions.begin() as session:
        acme, globex = create_key(session, "acme"), create_key(session, "globex")
    as_acme = {"Authorization": f"Bearer {acme}"}
    as_globex = {"Authorization": f"Bearer {globex}"}
    model = upload(client, CUBE, headers=as_acme).json()
    job_id = model["job"]["id"]
    assert client.get(f"/v1/jobs/{job_id}", headers=as_acme).status_code == 200
    assert client.get(f"/v1/jobs/{job_id}", headers=as_globex).status_code == 404
    assert client.get("/v1/jobs", headers=as_globex).json()["items"] == []
    assert [j["id"] for j in client.get("/v1/jobs", headers=as_acme).json()["items"]] == [job_id]
    assert client.get("/v1/stats", headers=as_globex).json()["models"] == 0
    assert client.get(f"/v1/models/{model['id']}/file", headers=as_globex).status_code == 404
    assert client.post(f"/v1/models/{model['id']}/redescribe",
                       headers=as_globex).status_code == 404
    hook = client.post("/v1/webhooks", headers=as_acme,
                       json={"url": "http://127.0.0.1:9/h", "events": ["model.ready"]}).json()
    assert client.get("/v1/webhooks", headers=as_globex).json()["items"] == []
    assert client.get(f"/v1/webhooks/{hook['id']}/deliveries",
                      headers=as_globex).status_code == 404
    assert client.delete(f"/v1/webhooks/{hook['id']}", headers=as_globex).status_code == 404
    assert client.get("/v1/jobs").status_code == 401
