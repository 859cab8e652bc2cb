"""The HTTP contract, on both backends, with an instant fake describer in the worker.

What the engine computes is tested in test_api_e2e.py; here: problem+json everywhere,
status codes, pagination, PATCH, tenants and keys, the upload limits, readiness and the
OpenAPI snapshot.
"""

from __future__ import annotations

import json
import os
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from prometheus_client import REGISTRY
from sqlalchemy import create_engine, text

from app.api.main import create_app
from app.auth.keys import create_key
from app.db.session import make_session_factory
from tests.conftest import PARTS, fake_describe, make_settings, upload, wait_for_status
from tests.search.test_hub_search import hub_order

SNAPSHOT = Path(__file__).parents[1] / "snapshots" / "openapi.json"
CUBE = PARTS / "20mm-xyz-cube.stl"
PROBLEM = "application/problem+json"

ClientFactory = Callable[..., TestClient]


@pytest.fixture
def make_client(database_url: str) -> Iterator[ClientFactory]:
    """``make_client(**settings)``: a started app (fake describer, embedded worker)."""
    clients: list[TestClient] = []

    def make(**overrides: Any) -> TestClient:
        settings = make_settings(database_url, **overrides)
        app = create_app(settings, embedded_worker=True, job_handler=fake_describe)
        client = TestClient(app, raise_server_exceptions=False)
        client.__enter__()
        clients.append(client)
        return client

    yield make
    for client in reversed(clients):
        client.__exit__(None, None, None)


@pytest.fixture
def client(make_client: ClientFactory) -> TestClient:
    return make_client()


def assert_problem(response: Any, status: int) -> dict[str, Any]:
    assert response.status_code == status, response.text
    assert response.headers["content-type"].startswith(PROBLEM)
    body = response.json()
    assert body["status"] == status
    for member in ("type", "title", "detail"):
        assert isinstance(body[member], str) and body[member], body
    return body


# --- models ---------------------------------------------------------------------------


def test_upload_is_accepted_and_becomes_ready(client: TestClient) -> None:
    response = upload(client, CUBE, external_id="cube-1", name="Cube", metadata='{"a": 1}')
    assert response.status_code == 202, response.text
    model = response.json()
    assert response.headers["location"] == f"/v1/models/{model['id']}"
    assert model["status"] in ("queued", "processing", "ready")
    assert model["external_id"] == "cube-1" and model["name"] == "Cube"
    assert model["metadata"] == {"a": 1}
    assert model["file"]["filename"] == CUBE.name
    assert model["file"]["format"] == "stl"
    assert model["file"]["size"] == CUBE.stat().st_size
    assert len(model["file"]["sha256"]) == 64

    ready = wait_for_status(client, model["id"])
    assert ready["status"] == "ready" and ready["error"] is None
    assert ready["cutoff"] == {
        "mode": "adaptive",
        "n": 10,
        "solver_calls": 2,
        "predicted": [10],
        "xi": 1e-10,
        "t": 1e-3,
        "seed": None,
        "n_min": 5,
        "n_max": 20,
        "margin": None,
        "prediction": None,
        "prediction_held": None,
        "features": None,
    }
    assert ready["descriptor_version"] == "fake-1"
    assert ready["n_points"] == 100

    listing = client.get("/v1/models", params={"external_id": "cube-1"}).json()
    assert [m["id"] for m in listing["items"]] == [model["id"]]


@pytest.mark.slow
def test_job_resource(client: TestClient) -> None:
    from sqlalchemy import select

    from app.db.models import Job

    model = upload(client, CUBE).json()
    wait_for_status(client, model["id"])
    services = client.app.state.services  # type: ignore[attr-defined]
    with services.sessions() as session:
        job_id = session.scalar(select(Job.id).where(Job.model_id == uuid.UUID(model["id"])))
    job = client.get(f"/v1/jobs/{job_id}").json()
    assert job["model_id"] == model["id"]
    assert job["status"] == "done" and job["attempts"] == 1 and job["last_error"] is None
    assert_problem(client.get(f"/v1/jobs/{uuid.uuid4()}"), 404)
    assert_problem(client.get("/v1/jobs/not-a-uuid"), 404)


def test_duplicate_external_id_is_409_naming_the_model(client: TestClient) -> None:
    first = upload(client, CUBE, external_id="part-7").json()
    body = assert_problem(upload(client, CUBE, external_id="part-7"), 409)
    assert first["id"] in body["detail"]
    assert body["existing_id"] == first["id"]
    assert upload(client, CUBE).status_code == 202  # no external id: no conflict
    assert upload(client, CUBE).status_code == 202


def test_unknown_and_malformed_ids_are_404(client: TestClient) -> None:
    assert_problem(client.get(f"/v1/models/{uuid.uuid4()}"), 404)
    assert_problem(client.get("/v1/models/not-a-uuid"), 404)
    assert_problem(client.delete("/v1/models/not-a-uuid"), 404)
    assert_problem(client.patch("/v1/models/xyz", json={"name": "n"}), 404)
    assert_problem(client.get(f"/v1/models/{uuid.uuid4()}/similar"), 404)


def test_similar_needs_a_ready_model(make_client: ClientFactory) -> None:
    client = make_client(workers=0)  # nothing gets described
    model = upload(client, CUBE).json()
    body = assert_problem(client.get(f"/v1/models/{model['id']}/similar"), 409)
    assert body["model_status"] == "queued"


def test_patch_changes_name_and_metadata_only(client: TestClient) -> None:
    model = upload(client, CUBE, name="old", metadata='{"x": 1}').json()
    renamed = client.patch(f"/v1/models/{model['id']}", json={"name": "new"})
    assert renamed.status_code == 200
    assert renamed.json()["name"] == "new" and renamed.json()["metadata"] == {"x": 1}
    tagged = client.patch(f"/v1/models/{model['id']}", json={"metadata": {"y": [1, 2]}}).json()
    assert tagged["name"] == "new" and tagged["metadata"] == {"y": [1, 2]}
    assert tagged["updated_at"] >= model["updated_at"]
    assert client.get(f"/v1/models/{model['id']}").json()["metadata"] == {"y": [1, 2]}
    assert_problem(client.patch(f"/v1/models/{model['id']}", json={"metadata": [1]}), 422)
    assert_problem(client.patch(f"/v1/models/{model['id']}", json={"metadata": None}), 422)
    assert_problem(client.patch(f"/v1/models/{model['id']}", json={"colour": "red"}), 422)


def test_pagination_visits_every_model_once_newest_first(client: TestClient) -> None:
    ids = [upload(client, CUBE, external_id=f"p{i}").json()["id"] for i in range(7)]
    seen: list[str] = []
    cursor = None
    pages = 0
    while True:
        params: dict[str, Any] = {"limit": 3}
        if cursor:
            params["cursor"] = cursor
        page = client.get("/v1/models", params=params).json()
        seen += [m["id"] for m in page["items"]]
        pages += 1
        cursor = page["next_cursor"]
        if cursor is None:
            break
    assert pages == 3
    assert seen == list(reversed(ids))
    assert_problem(client.get("/v1/models", params={"limit": 501}), 422)
    assert_problem(client.get("/v1/models", params={"limit": 0}), 422)
    assert_problem(client.get("/v1/models", params={"cursor": "garbage!"}), 422)
    ready = client.get("/v1/models", params={"status": "ready", "limit": 500}).json()
    assert all(m["status"] == "ready" for m in ready["items"])


def test_delete_is_204_then_404(client: TestClient) -> None:
    model = upload(client, CUBE).json()
    wait_for_status(client, model["id"])
    assert client.delete(f"/v1/models/{model['id']}").status_code == 204
    assert_problem(client.get(f"/v1/models/{model['id']}"), 404)
    assert_problem(client.delete(f"/v1/models/{model['id']}"), 404)
    assert len(client.app.state.services.index) == 0  # type: ignore[attr-defined]


@pytest.mark.slow
def test_similar_with_metadata_filters_returns_k_matches(
    client: TestClient, make_client: ClientFactory
) -> None:
    parts = sorted(p for p in PARTS.iterdir() if p.is_file() and p.suffix.lower() == ".stl")
    ids = []
    for i, path in enumerate(parts):
        family = "even" if i % 2 == 0 else "odd"
        meta = json.dumps({"family": family, "i": i})
        ids.append(upload(client, path, metadata=meta).json()["id"])
    for model_id in ids:
        wait_for_status(client, model_id)
    query = ids[0]
    unfiltered = client.get(f"/v1/models/{query}/similar", params={"k": 100}).json()
    assert len(unfiltered["results"]) == len(ids) - 1
    answer = [r["model"]["id"] for r in unfiltered["results"]]
    assert query not in answer
    # Ordered with the hub discount and re-ranked k-reciprocally (tests/test_hub_search.py),
    # computed here from the fake describer's vectors; scores stay the plain similarity.
    vectors = {i: np.frombuffer(fake_describe(p.read_bytes(), p.name)["descriptor"], np.float32)
               for i, p in zip(ids, parts, strict=True)}
    assert answer == hub_order(vectors, vectors[query], 100, 10, exclude=query, reciprocal=True)
    scores = [r["score"] for r in unfiltered["results"]]
    assert all(0 <= s <= 1 for s in scores)
    plain = make_client(search_hub_neighbours=0)  # the same database, plain order
    plain_scores = [r["score"] for r in plain.get(
        f"/v1/models/{query}/similar", params={"k": 100}).json()["results"]]
    assert plain_scores == sorted(scores, reverse=True) != scores

    odd = client.get(f"/v1/models/{query}/similar", params={"k": 2, "metadata.family": "odd"})
    results = odd.json()["results"]
    assert len(results) == 2
    assert all(r["model"]["metadata"]["family"] == "odd" for r in results)
    one = client.get(f"/v1/models/{query}/similar", params={"k": 5, "metadata.i": "3"}).json()
    assert [r["model"]["id"] for r in one["results"]] == [ids[3]]
    none = client.get(f"/v1/models/{query}/similar", params={"metadata.family": "x"}).json()
    assert none["results"] == []
    high = client.get(f"/v1/models/{query}/similar", params={"k": 100, "min_score": 0.99})
    assert all(r["score"] >= 0.99 for r in high.json()["results"])
    assert_problem(client.get(f"/v1/models/{query}/similar", params={"k": 0}), 422)
    assert_problem(client.get(f"/v1/models/{query}/similar", params={"k": 101}), 422)


# --- upload refusals --------------------------------------------------------------------


def test_413_when_the_file_is_larger_than_the_limit(make_client: ClientFactory) -> None:
    client = make_client(max_upload_bytes=1000)
    body = assert_problem(upload(client, CUBE), 413)  # counted while reading
    assert "1000" in body["detail"]
    # A declared Content-Length beyond the limit is refused before the body is read.
    huge = client.post(
        "/v1/models",
        content=b"x" * 200_000,
        headers={"content-type": "multipart/form-data; boundary=b"},
    )
    assert_problem(huge, 413)
    assert client.get("/v1/models").json()["items"] == []


def test_415_for_an_unknown_format(client: TestClient) -> None:
    response = client.post("/v1/models", files={"file": ("part.docx", b"\x00\x01binary junk")})
    body = assert_problem(response, 415)
    assert body["reason"] == "unknown_format"


def test_422_for_content_refused_at_upload(client: TestClient) -> None:
    empty = assert_problem(client.post("/v1/models", files={"file": ("e.stl", b"")}), 422)
    assert empty["reason"] == "empty_file"
    few = b"".join(f"{i} {i * 2} {i * 3}\n".encode() for i in range(5))
    assert assert_problem(client.post("/v1/models", files={"file": ("few.xyz", few)}), 422)
    nan = b"".join(b"nan 1 2\n" for _ in range(300))
    assert_problem(client.post("/v1/models", files={"file": ("nan.xyz", nan)}), 422)
    assert client.get("/v1/models").json()["items"] == []


def out_of_memory(*args: Any) -> None:
    """A stand-in for a step that finds this process short of memory."""
    raise MemoryError


def test_503_not_422_when_the_quick_check_runs_out_of_memory(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A small file is parsed in the API's own process: a MemoryError there is the service's
    # shortage, not the file's fault, so the client is told to retry, not that it is broken.
    monkeypatch.setattr("app.api.uploads.quick_check", out_of_memory)
    body = assert_problem(upload(client, CUBE), 503)
    assert body["type"].endswith(":busy") and "retry" in body["detail"].lower()
    assert int(upload(client, CUBE).headers["Retry-After"]) > 0
    put = client.put("/v1/models/by-external-id/P-1",
                     files={"file": ("cube.stl", CUBE.read_bytes())})
    assert_problem(put, 503)
    assert client.get("/v1/models").json()["items"] == []
    monkeypatch.undo()  # memory back: the same file is accepted
    assert upload(client, CUBE).status_code == 202


def test_the_quick_check_leaves_the_size_to_the_describe(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Measuring a large, round mesh is most of its load, and a size is never a reason to
    # refuse a file: the check only parses and samples (a measure that ran out of memory
    # here would answer 503).
    monkeypatch.setattr("core.size.ShapeSize.of_mesh", out_of_memory)
    assert upload(client, CUBE).status_code == 202


# Over IN_PROCESS_CHECK_MAX_BYTES (256 KiB), so its quick check runs in a sandboxed child:
# every coordinate row holds a NaN, which that check refuses with 422.
NAN_CLOUD = b"nan 1 2\n" * 40_000


def unchecked_uploads(reason: str) -> float:
    """``shapesearch_uploads_unchecked_total{reason}`` as this process's metrics show it."""
    return REGISTRY.get_sample_value("shapesearch_uploads_unchecked_total",
                                     {"reason": reason}) or 0.0


@pytest.mark.slow
def test_a_quick_check_out_of_time_lets_the_upload_through(make_client: ClientFactory) -> None:
    """The quick check is a courtesy bounded in time (a file can hang its reader for ever):
    past its limit the upload is accepted unchecked, and the worker's describe decides."""
    checked = make_client()
    body = assert_problem(checked.post("/v1/models", files={"file": ("nan.xyz", NAN_CLOUD)}), 422)
    assert body["reason"] == "non_finite"

    hurried = make_client(upload_check_timeout_seconds=0.001)  # no child answers in 1 ms
    before = unchecked_uploads("timeout")
    accepted = hurried.post("/v1/models", files={"file": ("nan.xyz", NAN_CLOUD)})
    assert accepted.status_code == 202, accepted.text
    assert unchecked_uploads("timeout") == before + 1
    # A small file is still checked in-process, whatever the limit.
    assert_problem(hurried.post("/v1/models", files={"file": ("e.xyz", b"nan 1 2\n" * 300)}), 422)


@pytest.mark.slow
def test_sandboxed_quick_checks_are_bounded_in_number(make_client: ClientFactory) -> None:
    """At most ``upload_check_max_concurrent`` check children per process: an upload that
    finds every slot taken for the whole time limit is accepted unchecked, and checked
    again as soon as a slot is free."""
    client = make_client(upload_check_max_concurrent=1, upload_check_timeout_seconds=0.5)
    slots = client.app.state.services.uploads._slots
    before = unchecked_uploads("busy")
    assert slots.acquire(timeout=5)  # another upload's check holds the only slot
    try:
        waited = client.post("/v1/models", files={"file": ("nan.xyz", NAN_CLOUD)})
    finally:
        slots.release()
    assert waited.status_code == 202, waited.text
    assert unchecked_uploads("busy") == before + 1
    freed = client.post("/v1/models", files={"file": ("nan.xyz", NAN_CLOUD)})
    assert assert_problem(freed, 422)["reason"] == "non_finite"


def test_422_for_metadata_that_is_not_an_object(client: TestClient) -> None:
    for bad in ("[1, 2]", "3", "{broken", '"text"'):
        body = assert_problem(upload(client, CUBE, metadata=bad), 422)
        assert "metadata" in body["detail"]


# --- problem+json for framework errors -------------------------------------------------


@pytest.mark.slow
def test_framework_errors_are_problem_json(client: TestClient) -> None:
    assert_problem(client.get("/no/such/route"), 404)
    assert_problem(client.put("/v1/models"), 405)
    missing_file = assert_problem(client.post("/v1/models", data={"name": "x"}), 422)
    assert missing_file["errors"][0]["loc"][-1] == "file"
    assert_problem(client.patch(f"/v1/models/{uuid.uuid4()}", content=b"{not json"), 422)


@pytest.mark.parametrize(("content_type", "body"), [
    ("multipart/form-data; boundary=xx", b"garbage"),  # no part at all
    ("multipart/form-data", b"--xx\r\n"),  # no boundary parameter
])
def test_a_body_that_cannot_be_parsed_is_its_own_kind(
    client: TestClient, content_type: str, body: bytes
) -> None:
    """Not about:blank: a client tells a broken multipart encoding from other 400s by
    its type, as every other refusal (app/problems.py)."""
    for path in ("/v1/models", "/v1/search"):
        refused = assert_problem(
            client.post(path, content=body, headers={"content-type": content_type}), 400
        )
        assert refused["type"] == "urn:shapesearch:problem:malformed-body"
        assert refused["title"] == "Malformed request body"
    assert client.get("/v1/models").json()["items"] == []  # nothing stored


# --- tenants and keys -------------------------------------------------------------------


@pytest.mark.slow
def test_keys_separate_tenants(make_client: ClientFactory, database_url: str) -> None:
    # No lookup cached: the keys made behind the app's back are seen at once
    # (test_auth_cache.py covers the cached default).
    client = make_client(auth_cache_seconds=0)
    open_model = upload(client, CUBE).json()  # before any key: the open "default" tenant
    engine = create_engine(database_url)
    with make_session_factory(engine).begin() as session:
        alice = {"Authorization": f"Bearer {create_key(session, 'alice')}"}
        bob = {"Authorization": f"Bearer {create_key(session, 'bob')}"}
    engine.dispose()

    unauthenticated = assert_problem(client.get("/v1/models"), 401)
    assert unauthenticated["type"].endswith("unauthorized")
    assert client.get("/v1/models").headers["www-authenticate"].startswith("Bearer")
    assert_problem(client.get("/v1/models", headers={"Authorization": "Bearer ss_wrong"}), 401)
    assert_problem(upload(client, CUBE), 401)
    assert client.get("/healthz").status_code == 200  # health stays open

    mine = upload(client, CUBE, headers=alice, external_id="shared-name").json()
    theirs = upload(client, CUBE, headers=bob, external_id="shared-name")
    assert theirs.status_code == 202  # external ids are unique per tenant only
    wait_for_status(client, mine["id"], headers=alice)
    wait_for_status(client, theirs.json()["id"], headers=bob)

    assert client.get(f"/v1/models/{mine['id']}", headers=alice).status_code == 200
    assert_problem(client.get(f"/v1/models/{mine['id']}", headers=bob), 404)
    assert_problem(client.delete(f"/v1/models/{mine['id']}", headers=bob), 404)
    assert_problem(client.get(f"/v1/models/{open_model['id']}", headers=alice), 404)
    assert [m["id"] for m in client.get("/v1/models", headers=alice).json()["items"]] == [
        mine["id"]
    ]
    similar = client.get(f"/v1/models/{mine['id']}/similar", headers=alice).json()
    assert similar["results"] == []  # bob's identical file is not alice's to see


def test_require_api_keys_closes_the_service(make_client: ClientFactory) -> None:
    client = make_client(require_api_keys=True)
    assert_problem(client.get("/v1/models"), 401)


# --- readiness --------------------------------------------------------------------------


def test_readyz_fails_when_the_index_is_out_of_step(
    make_client: ClientFactory, database_url: str
) -> None:
    client = make_client(readyz_count_seconds=0)  # count on every probe
    assert client.get("/healthz").json() == {"status": "ok"}
    model = upload(client, CUBE).json()
    wait_for_status(client, model["id"])
    ready = client.get("/readyz")
    assert ready.status_code == 200 and ready.json()["status"] == "ok"

    # Remove the model behind the index's back: no change-feed event.
    engine = create_engine(database_url)
    with engine.begin() as connection:
        hex_id = uuid.UUID(model["id"]).hex
        connection.execute(text("DELETE FROM jobs"))
        connection.execute(text("DELETE FROM uploads"))
        connection.execute(
            text("DELETE FROM models WHERE CAST(id AS TEXT) IN (:a, :b)"),
            {"a": hex_id, "b": model["id"]},
        )
    engine.dispose()
    body = assert_problem(client.get("/readyz"), 503)
    assert "index" in body["detail"] and body["checks"]["index"] != "ok"


@pytest.mark.slow
def test_similar_by_id_answers_from_the_database_when_the_index_lags(
    make_client: ClientFactory, database_url: str
) -> None:
    """The query vector comes from the index, but the database decides: a model changed
    behind the index's back (no change-feed event, so the index still holds it) is 409
    while it is being described and 404 once gone, not answered from the stale copy."""
    # No answer kept (response_cache_seconds=0): this is about the path that computes one.
    client = make_client(index_sync_interval=3600, response_cache_seconds=0)
    models = [upload(client, path).json() for path in (CUBE, PARTS / "cylinder.stl")]
    for model in models:
        wait_for_status(client, model["id"])
    query, other = models
    similar = f"/v1/models/{query['id']}/similar"
    assert [r["model"]["id"] for r in client.get(similar).json()["results"]] == [other["id"]]

    engine = create_engine(database_url)
    ids = {"a": uuid.UUID(query["id"]).hex, "b": query["id"]}
    where = "WHERE CAST(id AS TEXT) IN (:a, :b)"
    with engine.begin() as connection:
        connection.execute(text(f"UPDATE models SET status = 'processing' {where}"), ids)
    assert assert_problem(client.get(similar), 409)["model_status"] == "processing"
    with engine.begin() as connection:
        connection.execute(text("DELETE FROM jobs"))
        connection.execute(text("DELETE FROM uploads"))
        connection.execute(text("DELETE FROM model_revisions"))
        connection.execute(text(f"DELETE FROM models {where}"), ids)
    engine.dispose()
    assert_problem(client.get(similar), 404)


# --- OpenAPI ----------------------------------------------------------------------------


def test_openapi_matches_the_snapshot() -> None:
    schema = create_app(make_settings("sqlite://")).openapi()
    rendered = json.dumps(schema, indent=2, sort_keys=True) + "\n"
    if os.environ.get("SHAPESEARCH_UPDATE_SNAPSHOTS") == "1":
        SNAPSHOT.parent.mkdir(parents=True, exist_ok=True)
        SNAPSHOT.write_text(rendered)
    assert SNAPSHOT.exists(), "no snapshot: run with SHAPESEARCH_UPDATE_SNAPSHOTS=1"
    assert rendered == SNAPSHOT.read_text(), (
        "The OpenAPI schema changed. If the change is intended, refresh the snapshot with "
        "SHAPESEARCH_UPDATE_SNAPSHOTS=1 python -m pytest tests/test_api.py -k openapi "
        "and commit tests/snapshots/openapi.json."
    )


def test_a_stored_file_keeps_only_its_base_name(client: TestClient) -> None:
    """A client's directory part (``../../``, ``C:\\``) is never stored, shown or served."""
    for sent in ("../../../../etc/passwd.stl", "C:\\parts\\cube.stl"):
        response = client.post(
            "/v1/models", files={"file": (sent, CUBE.read_bytes(), "application/octet-stream")}
        )
        assert response.status_code == 202, response.text
        model = response.json()
        expected = sent.replace("\\", "/").rsplit("/", 1)[-1]
        assert model["file"]["filename"] == expected
        wait_for_status(client, model["id"])
        served = client.get(f"/v1/models/{model['id']}/file")
        assert served.status_code == 200
        assert f'filename="{expected}"' in served.headers["content-disposition"]


@pytest.mark.slow
def test_cors_is_off_by_default_and_answers_preflights_for_configured_origins(
    make_client: ClientFactory,
) -> None:
    preflight = {"Origin": "https://plm.example.com", "Access-Control-Request-Method": "POST",
                 "Access-Control-Request-Headers": "authorization"}
    closed = make_client()
    answer = closed.options("/v1/models", headers=preflight)
    assert "access-control-allow-origin" not in answer.headers
    opened = make_client(cors_origins="https://plm.example.com, https://other.example.com")
    answer = opened.options("/v1/models", headers=preflight)
    assert answer.status_code == 200
    assert answer.headers["access-control-allow-origin"] == "https://plm.example.com"
    assert "POST" in answer.headers["access-control-allow-methods"]
    assert "authorization" in answer.headers["access-control-allow-headers"].lower()
    stranger = opened.options("/v1/models", headers={**preflight, "Origin": "https://evil.test"})
    assert "access-control-allow-origin" not in stranger.headers
    simple = opened.get("/v1/models", headers={"Origin": "https://other.example.com"})
    assert simple.headers["access-control-allow-origin"] == "https://other.example.com"
    assert "location" in simple.headers["access-control-expose-headers"].lower()


@pytest.mark.slow
def test_the_contract_has_readable_operation_ids_and_one_problem_component(
    client: TestClient,
) -> None:
    document = client.get("/openapi.json").json()
    operations = [op for path in document["paths"].values() for op in path.values()]
    ids = [op["operationId"] for op in operations]
    assert len(ids) == len(set(ids))
    assert {"upload_model", "similar_models", "search_by_upload", "upsert_model"} <= set(ids)
    assert all(identifier.isidentifier() and "_v1_" not in identifier for identifier in ids)
    refused = [
        response["content"]["application/problem+json"]["schema"]
        for op in operations
        for status, response in op["responses"].items()
        if status[0] in "45"
    ]
    assert refused and all(s == {"$ref": "#/components/schemas/Problem"} for s in refused)
    assert "HTTPValidationError" not in document["components"]["schemas"]
