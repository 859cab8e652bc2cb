"""The hot reads' answers built as plain values (app.api.answers) and answered without
FastAPI's routing (app.api.hot_reads): byte for byte what the routes' pydantic models give,
on both backends, and every request the short way cannot answer alike goes the usual way."""

from __future__ import annotations

import json
import uuid
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import create_engine, select, update

from app.api.answers import json_body, similar_body, stored_time, stored_uuid
from app.api.main import create_app
from app.api.schemas import (
    ModelList,
    SimilarQuery,
    SimilarResponse,
    model_resource,
    similar_results,
)
from app.auth.keys import create_key
from app.db.models import Model
from app.db.session import make_session_factory
from app.ingest.revisions import latest_jobs
from app.search.similarity import Candidate, Match
from core.rank.score_calibration import _table
from core.size import ShapeSize
from tests.conftest import PARTS, fake_describe, make_settings, upload, wait_for_status

PARTS_USED = ("20mm-xyz-cube.stl", "cylinder.stl", "angle_block.STL", "plate_holes.STL",
              "octagonal_pocket.stl")


@pytest.fixture
def client(database_url: str) -> Iterator[TestClient]:
    settings = make_settings(database_url, response_cache_seconds=0)
    with TestClient(create_app(settings, embedded_worker=True, job_handler=fake_describe),
                    raise_server_exceptions=False) as c:
        yield c


@pytest.fixture
def model_ids(client: TestClient, database_url: str) -> list[str]:
    ids = []
    for number, name in enumerate(PARTS_USED):
        meta = {"kind": "plate", "qty": number, "big": 123456789012345678901234567890,
                "nested": {"a": [1, 2.5, None, True]}} if number % 2 else {}
        ids.append(upload(client, PARTS / name, name=name,
                          metadata=json.dumps(meta)).json()["id"])
    for model_id in ids:
        wait_for_status(client, model_id)
    # One model with a size, an error and a cutoff holding integers where floats are declared.
    engine = create_engine(database_url)
    with engine.begin() as connection:
        connection.execute(update(Model).where(Model.id == uuid.UUID(ids[1])).values(
            size_length=20.0, size_width=10.5, size_height=1.0, size_area=500.0,
            size_volume=None, units="mm"))
        connection.execute(update(Model).where(Model.id == uuid.UUID(ids[2])).values(
            error={"type": "t", "title": "T", "detail": "d", "extra": 1},
            cutoff={"mode": "adaptive", "n": 12, "solver_calls": 1, "xi": 1, "t": 0.01,
                    "features": [1, 2.5], "predicted": []}))
    engine.dispose()
    return ids


def _expected_page(client: TestClient, limit: int, cursor: str | None = None) -> bytes:
    """``GET /v1/models?limit=`` as the ``ModelList`` model writes it, from the ORM."""
    services = client.app.state.services  # type: ignore[attr-defined]
    with services.sessions() as session:
        models = session.scalars(
            select(Model).where(Model.tenant == "default")
            .order_by(Model.created_at.desc(), Model.id.desc())).all()
        start = 0
        if cursor is not None:
            start = 1 + next(i for i, m in enumerate(models)
                             if f"-{m.id.hex}" in cursor)
        page = models[start : start + limit]
        jobs = latest_jobs(session, [m.id for m in page])
        from app.api.cursors import encode_keyset
        more = len(models) > start + limit
        answer = ModelList(items=[model_resource(m, jobs.get(m.id)) for m in page],
                           next_cursor=encode_keyset(page[-1]) if more else None)
    return answer.model_dump_json(by_alias=True).encode()


def test_a_page_is_what_the_model_writes(client: TestClient, model_ids: list[str]) -> None:
    cursor = None
    for _ in range(4):
        path = "/v1/models?limit=2" + (f"&cursor={cursor}" if cursor else "")
        answer = client.get(path)
        assert answer.status_code == 200
        assert answer.content == _expected_page(client, 2, cursor)
        cursor = answer.json()["next_cursor"]
        if cursor is None:
            break
    assert client.get("/v1/models").content == _expected_page(client, 50)


def _similar_expected(client: TestClient, model_id: str, k: int) -> bytes:
    """The similar answer as ``SimilarResponse`` writes it, from ``find_similar``."""
    from app.search.similarity import find_similar

    services = client.app.state.services  # type: ignore[attr-defined]
    index = services.index
    index_id, key = index.locate("default", uuid.UUID(model_id))
    with services.reader.connect() as connection:
        matches = find_similar(index, connection, key, index.vector(key, index_id), k=k,
                               exclude=index_id, indexed_query=True)
    answer = SimilarResponse(query=SimilarQuery(model_id=uuid.UUID(model_id)),
                             results=similar_results(matches, key[1]))
    return answer.model_dump_json(by_alias=True).encode()


def test_a_similar_list_is_what_the_model_writes(client: TestClient,
                                                 model_ids: list[str]) -> None:
    for model_id in model_ids:
        for k in (1, 3, 10):
            answer = client.get(f"/v1/models/{model_id}/similar?k={k}")
            assert answer.status_code == 200
            assert answer.content == _similar_expected(client, model_id, k)


@pytest.mark.slow
@pytest.mark.parametrize("plain, unusual", [
    # Each pair asks the same; the second only FastAPI reads (app.api.hot_reads).
    ("/v1/models?limit=3", "/v1/models?limit=03"),
    ("/v1/models?limit=3&status=ready", "/v1/models?status=ready&limit=3&cursor="),
    ("/v1/models", "/v1/models?limit=050"),
    ("/SIMILAR?k=3", "/SIMILAR?k=+3"),
    ("/SIMILAR", "/SIMILAR?size_weight=0"),
    ("/SIMILAR?min_score=0.5", "/SIMILAR?min_score=0.50&k=10"),
    ("/SIMILAR?mode=scan&k=2", "/SIMILAR?mode=scan&k=2&size_weight=0"),
])
def test_the_short_way_answers_as_the_route(client: TestClient, model_ids: list[str],
                                            plain: str, unusual: str) -> None:
    similar = f"/v1/models/{model_ids[0]}/similar"
    first = client.get(plain.replace("/SIMILAR", similar))
    second = client.get(unusual.replace("/SIMILAR", similar))
    assert first.status_code == 200, first.text
    assert (first.content, first.headers["content-type"]) == (
        second.content, second.headers["content-type"])


def test_what_the_short_way_refuses_the_route_answers(client: TestClient,
                                                      model_ids: list[str],
                                                      database_url: str) -> None:
    similar = f"/v1/models/{model_ids[0]}/similar"
    assert client.get(f"{similar}?k=0").status_code == 422
    assert client.get(f"{similar}?k=101").status_code == 422
    assert client.get(f"{similar}?min_score=2").status_code == 422
    assert client.get(f"{similar}?mode=other").status_code == 422
    assert client.get("/v1/models?limit=0").status_code == 422
    assert client.get("/v1/models?status=gone").status_code == 422
    assert client.get("/v1/models?cursor=nonsense").status_code == 422
    assert client.get(f"/v1/models/{uuid.uuid4()}/similar").status_code == 404
    assert client.get("/v1/models/not-an-id/similar").status_code == 404
    # Keys: once one exists, an unknown key and no key are refused, a good one is served.
    engine = create_engine(database_url)
    with make_session_factory(engine).begin() as session:
        key = create_key(session, "default")
    engine.dispose()
    del client.app.state.auth_cache  # type: ignore[attr-defined]  # forget "open"
    for headers in ({}, {"Authorization": "Bearer ss_0123456789abcdefnot-a-key-at-all"}):
        for _ in range(2):  # the second time from the auth cache
            assert client.get(similar, headers=headers).status_code == 401
            assert client.get("/v1/models", headers=headers).status_code == 401
    good = {"Authorization": f"Bearer {key}"}
    for _ in range(2):
        assert client.get(similar, headers=good).status_code == 200
        assert client.get("/v1/models", headers=good).status_code == 200
    assert client.get(similar, headers={"Authorization": f"bearer {key}"}).status_code == 200


def test_a_short_answer_is_labelled_with_its_route(client: TestClient,
                                                   model_ids: list[str]) -> None:
    from prometheus_client import REGISTRY

    labels = {"method": "GET", "route": "/v1/models/{model_id}/similar", "status": "200"}
    before = REGISTRY.get_sample_value("shapesearch_http_requests_total", labels) or 0.0
    for _ in range(3):
        assert client.get(f"/v1/models/{model_ids[0]}/similar?k=2").status_code == 200
    after = REGISTRY.get_sample_value("shapesearch_http_requests_total", labels) or 0.0
    assert after - before == 3


def _match(number: int, size: bool, meta: dict[str, Any] | None) -> Match:
    candidate = Candidate(
        number, uuid.UUID(int=number * 7919 + 1), None if number % 2 else f"E-{number}",
        f"part {number}", meta,
        ShapeSize(20.5, 10.0, 1.0, 400.25, None if number % 3 else 99.5) if size else None,
        "mm" if size and number % 2 else None)
    distance = 0.05 * number
    return Match(candidate, distance, 1.0 - distance * distance / 4.0)


@pytest.mark.parametrize("version", ["fake-1", next(iter(_table()), "fake-2") + ";0123456789"])
def test_similar_values_are_what_the_model_writes(version: str) -> None:
    matches = [_match(number, number % 2 == 0, meta) for number, meta in enumerate(
        [None, {}, {"a": 1, "f": 1e-7, "nan": float("nan"), "s": "é\u2028\x1f"},
         {"nested": {"x": [1, 2.5, None, True, "y"]}}], start=1)]
    # And one that orjson refuses (an integer beyond 64 bits): pydantic-core writes it.
    matches_big = [*matches, _match(9, True, {"big": 10**30})]
    model_id = uuid.uuid4()
    expected = SimilarResponse(query=SimilarQuery(model_id=model_id),
                               results=similar_results(matches, version))
    assert json_body(similar_body(model_id, matches, version)) == (
        expected.model_dump_json(by_alias=True).encode())
    expected = SimilarResponse(query=SimilarQuery(model_id=model_id),
                               results=similar_results(matches_big, version))
    assert json_body(similar_body(model_id, matches_big, version)) == (
        expected.model_dump_json(by_alias=True).encode())
    assert json_body(similar_body(model_id, [], version)) == SimilarResponse(
        query=SimilarQuery(model_id=model_id), results=[]).model_dump_json().encode()


def test_stored_text_is_written_as_the_types_write_it() -> None:
    from datetime import UTC, datetime

    import pydantic_core

    for stored, moment in [("2026-12-07 15:23:35.960899", datetime(2026, 12, 7, 15, 23, 35,
                                                                     960899, UTC)),
                           ("2026-12-07 15:23:35.000000", datetime(2026, 12, 7, 15, 23, 35,
                                                                     tzinfo=UTC)),
                           ("2026-12-07 15:23:35.960000", datetime(2026, 12, 7, 15, 23, 35,
                                                                     960000, UTC)),
                           ("2026-12-07 15:23:35", datetime(2026, 12, 7, 15, 23, 35,
                                                              tzinfo=UTC))]:
        assert json_body(stored_time(stored)) == pydantic_core.to_json(moment)
    number = uuid.uuid4()
    assert json_body(stored_uuid(number.hex)) == pydantic_core.to_json(number)
    assert json_body(stored_uuid(number.hex.upper())) == pydantic_core.to_json(number)
