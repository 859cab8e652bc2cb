"""The micro-cache of model lists and similar lists (app.api.response_cache): repeats are
served from memory, this process's writes and index changes are seen at once, other changes
within response_cache_seconds, and one key's answers never reach another key."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient
from prometheus_client import REGISTRY
from sqlalchemy import create_engine, update

from app.api.main import create_app
from app.auth.keys import create_key
from app.db.models import Model
from app.db.session import make_session_factory
from tests.conftest import PARTS, fake_describe, make_settings, upload, wait_for_status

SECONDS = 2.0


@pytest.fixture
def client(database_url: str) -> Iterator[TestClient]:
    settings = make_settings(database_url, response_cache_seconds=SECONDS)
    with TestClient(create_app(settings, embedded_worker=True, job_handler=fake_describe)) as c:
        yield c


def _names(client: TestClient, headers: dict[str, str] | None = None) -> list[str | None]:
    return [m["name"] for m in client.get("/v1/models", headers=headers).json()["items"]]


def _rename_behind_its_back(database_url: str, name: str) -> None:
    """What another process's write looks like to this one: nothing passes through it."""
    engine = create_engine(database_url)
    with engine.begin() as connection:
        connection.execute(update(Model).values(name=name))
    engine.dispose()


@pytest.mark.slow
def test_a_repeat_is_served_from_memory_until_it_expires(
    client: TestClient, database_url: str
) -> None:
    model_id = upload(client, PARTS / "20mm-xyz-cube.stl", name="cube").json()["id"]
    wait_for_status(client, model_id)
    assert _names(client) == ["cube"]
    _rename_behind_its_back(database_url, "renamed")
    changed_at = time.monotonic()
    assert _names(client) == ["cube"]  # kept: the database was not asked
    while _names(client) == ["cube"]:
        assert time.monotonic() - changed_at < SECONDS + 1.0
        time.sleep(0.05)
    assert _names(client) == ["renamed"]


def test_this_process_writes_and_index_changes_are_seen_at_once(client: TestClient) -> None:
    first = upload(client, PARTS / "20mm-xyz-cube.stl", name="cube").json()["id"]
    wait_for_status(client, first)
    assert _names(client) == ["cube"]
    assert client.get(f"/v1/models/{first}/similar").json()["results"] == []
    # A PATCH answered by this process drops what was kept.
    assert client.patch(f"/v1/models/{first}", json={"name": "block"}).status_code == 200
    assert _names(client) == ["block"]
    # A model that the worker finishes enters the index: the similar list changes at once.
    second = upload(client, PARTS / "round.stl", name="round").json()["id"]
    wait_for_status(client, second)
    similar = client.get(f"/v1/models/{first}/similar").json()["results"]
    assert [r["model"]["id"] for r in similar] == [second]


def test_one_key_never_gets_another_keys_answer(client: TestClient, database_url: str) -> None:
    engine = create_engine(database_url)
    with make_session_factory(engine).begin() as session:
        alice = {"Authorization": f"Bearer {create_key(session, 'alice')}"}
        bob = {"Authorization": f"Bearer {create_key(session, 'bob')}"}
    engine.dispose()
    model_id = upload(client, PARTS / "20mm-xyz-cube.stl", name="a", headers=alice).json()["id"]
    wait_for_status(client, model_id, headers=alice)
    assert _names(client, alice) == ["a"]
    assert _names(client, bob) == []
    assert client.get("/v1/models").status_code == 401  # no key: not alice's kept answer


def test_a_hit_is_counted_under_its_route(client: TestClient) -> None:
    labels = {"method": "GET", "route": "/v1/models", "status": "200"}

    def listed() -> float:
        return REGISTRY.get_sample_value("shapesearch_http_requests_total", labels) or 0.0

    client.get("/v1/models")
    before = listed()
    for _ in range(5):
        client.get("/v1/models")
    assert listed() - before == 5


def test_a_hit_carries_its_own_request_headers(database_url: str) -> None:
    # Outer middleware add headers in place: a kept answer must not gather them.
    settings = make_settings(database_url, response_cache_seconds=SECONDS,
                             cors_origins="https://plm.example")
    with TestClient(create_app(settings, job_handler=fake_describe)) as client:
        for number in range(3):
            answer = client.get("/v1/models", headers={"Origin": "https://plm.example",
                                                       "X-Request-ID": f"req-{number}"})
            assert answer.headers["x-request-id"] == f"req-{number}"
            assert answer.headers.get_list("vary") == ["Origin"]
            assert answer.headers["access-control-allow-origin"] == "https://plm.example"


@pytest.mark.slow
def test_an_answer_is_the_same_with_the_cache_on_and_off(database_url: str) -> None:
    """One query's answer, cache on (the miss that fills it, then the hit) and cache off (each
    request computed): the same bytes, for a similar list and a page."""
    ids = []
    with TestClient(create_app(make_settings(database_url), embedded_worker=True,
                               job_handler=fake_describe)) as client:
        for name in ("20mm-xyz-cube.stl", "cylinder.stl", "angle_block.STL", "round.stl"):
            ids.append(upload(client, PARTS / name, name=name).json()["id"])
        for model_id in ids:
            wait_for_status(client, model_id)
    queries = [f"/v1/models/{ids[0]}/similar?k=2", f"/v1/models/{ids[1]}/similar",
               "/v1/models?limit=3", "/v1/models"]
    answers: dict[str, list[bytes]] = {query: [] for query in queries}
    for seconds in (SECONDS, 0.0):
        settings = make_settings(database_url, response_cache_seconds=seconds)
        with TestClient(create_app(settings, job_handler=fake_describe)) as client:
            for query in queries:
                for _ in range(2):  # cache on: the miss, then the hit
                    response = client.get(query)
                    assert response.status_code == 200
                    answers[query].append(response.content)
    for query, bodies in answers.items():
        assert len(set(bodies)) == 1, query
