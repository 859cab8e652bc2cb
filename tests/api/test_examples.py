"""The OpenAPI examples (app/api/examples.py) cover every /v1 call and are valid: each one
validates against the schema it illustrates, and the error examples name the problem types
the service really answers."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from jsonschema import Draft202012Validator, FormatChecker

from app.api.examples import EXAMPLES
from app.api.main import create_app
from tests.conftest import PARTS, make_settings

JSON_MEDIA = ("application/json", "application/problem+json", "multipart/form-data")


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TestClient]:
    path = tmp_path_factory.mktemp("examples") / "shapesearch.db"
    with TestClient(create_app(make_settings(f"sqlite:///{path}"))) as client:
        yield client


@pytest.fixture(scope="module")
def document(client: TestClient) -> dict[str, Any]:
    return client.get("/openapi.json").json()


def documented_media(document: dict[str, Any]) -> Iterator[tuple[str, str, str, dict[str, Any]]]:
    """(operation, where, media type, media object) of every /v1 body the docs show."""
    for path, operations in document["paths"].items():
        if not path.startswith("/v1/"):
            continue
        for method, operation in operations.items():
            name = f"{method.upper()} {path}"
            for media, body in operation.get("requestBody", {}).get("content", {}).items():
                yield name, "request", media, body
            for status, response in operation["responses"].items():
                for media, body in response.get("content", {}).items():
                    yield name, status, media, body


def is_framework_422(status: str, media: str) -> bool:
    """FastAPI's own entry for path-parameter errors (application/json): the service answers
    those as problem+json, which the entries listed by the routes document."""
    return status == "422" and media == "application/json"


def test_every_v1_call_has_examples(document: dict[str, Any]) -> None:
    operations = {
        f"{method.upper()} {path}"
        for path, ops in document["paths"].items()
        if path.startswith("/v1/")
        for method in ops
    }
    assert operations == {f"{m.upper()} {p}" for m, p in EXAMPLES}
    missing = [
        (name, where, media)
        for name, where, media, body in documented_media(document)
        if media in JSON_MEDIA and not is_framework_422(where, media) and "examples" not in body
    ]
    assert missing == []
    uploads = [media for name, where, media, body in documented_media(document)
               if where == "request" and media == "multipart/form-data" and "examples" in body]
    assert len(uploads) == 3  # POST /v1/models, PUT /v1/models/by-external-id/..., POST /v1/search


def test_every_example_validates_against_its_schema(document: dict[str, Any]) -> None:
    checked = 0
    for name, where, media, body in documented_media(document):
        for example in body.get("examples", {}).values():
            schema = {**body["schema"], "components": document["components"]}
            validator = Draft202012Validator(schema, format_checker=FormatChecker())
            errors = [error.message for error in validator.iter_errors(example["value"])]
            assert errors == [], f"{name} {where} {media}: {errors}"
            if where != "request" and int(where) >= 400:
                assert example["value"]["status"] == int(where), name
            component = body["schema"].get("$ref", "").removeprefix("#/components/schemas/")
            if component:
                known = set(document["components"]["schemas"][component]["properties"])
                assert set(example["value"]) <= known, f"{name} {where}: unknown fields"
            checked += 1
    assert checked >= 40


def test_error_examples_name_the_problem_types_the_service_answers(
    client: TestClient, document: dict[str, Any]
) -> None:
    def example(method: str, path: str, status: int) -> dict[str, Any]:
        return EXAMPLES[(method, path)]["responses"][status]

    points = (PARTS / "points_ascii.ply").read_bytes()
    model_id = example("get", "/v1/models/{model_id}", 200)["id"]
    unknown = client.post("/v1/models", files={"file": ("drawing.docx", b"not a shape")})
    few = client.post("/v1/models", files={"file": ("points.ply", points)})
    missing = client.get(f"/v1/models/{model_id}")
    big_k = client.get(f"/v1/models/{model_id}/similar?k=1000")
    no_report = client.get("/v1/duplicates", params={"size_tolerance": 0.02})
    for response, documented in (
        (unknown, example("post", "/v1/models", 415)),
        (few, example("post", "/v1/models", 422)),
        (missing, example("get", "/v1/models/{model_id}", 404)),
        (big_k, example("get", "/v1/models/{model_id}/similar", 422)),
        (no_report, example("get", "/v1/duplicates", 404)),
    ):
        real = response.json()
        assert response.status_code == documented["status"]
        assert (real["type"], real["title"]) == (documented["type"], documented["title"])
        assert set(real) == set(documented)
