"""Input limits: every bad text field, query parameter or metadata value is a 422 that
points at the field (never a 500 from the database driver or a RecursionError), on both
backends; problem details are consistent (one type per kind, one title per status)."""

from __future__ import annotations

import json
import re
import uuid
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient

from app.api.main import create_app
from tests.conftest import PARTS, fake_describe, make_settings, stored_duplicates

CUBE = (PARTS / "20mm-xyz-cube.stl").read_bytes()
VALIDATION = "urn:shapesearch:problem:validation-error"


@pytest.fixture
def client(database_url: str) -> Iterator[TestClient]:
    settings = make_settings(database_url, max_metadata_bytes=1000, max_metadata_depth=4)
    app = create_app(settings, embedded_worker=True, job_handler=fake_describe)
    with TestClient(app, raise_server_exceptions=False) as client:
        yield client


def post_model(client: TestClient, filename: str = "cube.stl", **form: str) -> Any:
    return client.post(
        "/v1/models", files={"file": (filename, CUBE, "application/octet-stream")}, data=form
    )


def patch_model(client: TestClient, model_id: str, body: str) -> Any:
    return client.patch(
        f"/v1/models/{model_id}", content=body, headers={"content-type": "application/json"}
    )


def assert_invalid(response: Any, pointer: str) -> dict[str, Any]:
    assert response.status_code == 422, response.text
    assert response.headers["content-type"].startswith("application/problem+json")
    body = response.json()
    assert body["type"] == VALIDATION
    assert body["title"] == "Invalid request"
    assert body["pointer"] == pointer, body
    return body


def nested(depth: int) -> str:
    return '{"a":' * depth + "1" + "}" * depth


@pytest.mark.slow
@pytest.mark.parametrize(
    ("form", "filename", "pointer"),
    [
        ({"external_id": "a\x00b"}, "cube.stl", "/external_id"),
        ({"name": "a\x00b"}, "cube.stl", "/name"),
        ({"name": "x" * 501}, "cube.stl", "/name"),
        ({"metadata": '{"x": NaN}'}, "cube.stl", "/metadata"),
        ({"metadata": '{"x": Infinity}'}, "cube.stl", "/metadata"),
        ({"metadata": nested(10_000)}, "cube.stl", "/metadata"),
        ({"metadata": "[" * 10_000 + "]" * 10_000}, "cube.stl", "/metadata"),
        ({"metadata": nested(5)}, "cube.stl", "/metadata/a/a/a/a"),
        ({"metadata": json.dumps({"k": "v" * 2000})}, "cube.stl", "/metadata"),
        ({"metadata": '{"k": "a\\u0000b"}'}, "cube.stl", "/metadata/k"),
        ({"metadata": '{"k": "\\ud800"}'}, "cube.stl", "/metadata/k"),
        ({"metadata": "[1]"}, "cube.stl", "/metadata"),
    ],
)
def test_bad_upload_fields_are_422_with_a_pointer(
    client: TestClient, form: dict[str, str], filename: str, pointer: str
) -> None:
    assert_invalid(post_model(client, filename, **form), pointer)
    assert client.get("/v1/models").json()["items"] == []  # nothing was stored
    assert client.get("/healthz").status_code == 200  # and the server is fine


def test_a_nul_in_the_file_name_is_422(client: TestClient) -> None:
    """Sent raw: httpx would percent-encode the NUL."""
    body = (
        b'--B\r\nContent-Disposition: form-data; name="file"; filename="a\x00b.stl"\r\n'
        b"Content-Type: application/octet-stream\r\n\r\n" + CUBE + b"\r\n--B--\r\n"
    )
    response = client.post(
        "/v1/models", content=body, headers={"content-type": "multipart/form-data; boundary=B"}
    )
    assert_invalid(response, "/file/filename")


@pytest.mark.slow
@pytest.mark.parametrize(
    ("route", "method"),
    [("/v1/models", "POST"), ("/v1/models/by-external-id/P-1", "PUT"), ("/v1/search", "POST")],
)
def test_a_form_field_given_twice_is_422_not_one_dropped(
    client: TestClient, route: str, method: str
) -> None:
    """The framework would keep the last of two files (or metadata objects) and drop the
    other without a word."""
    two_files = [("file", ("a.stl", CUBE)), ("file", ("b.stl", CUBE))]
    body = assert_invalid(client.request(method, route, files=two_files), "/file")
    assert "2 times" in body["detail"]
    one_file = {"file": ("a.stl", CUBE)}
    assert_invalid(client.request(method, route, files=one_file, data={"units": ["mm", "in"]}),
                   "/units")
    if route != "/v1/search":  # which takes no metadata
        two_metadata = {"metadata": ['{"a": 1}', '{"a": 2}']}
        assert_invalid(client.request(method, route, files=one_file, data=two_metadata),
                       "/metadata")
    assert client.get("/v1/models").json()["items"] == []  # none of them was stored
    # A field the route does not read is ignored, as the framework ignores it.
    ignored = client.request(method, route, files=one_file, data={"colour": ["red", "blue"]})
    assert ignored.status_code in (200, 201, 202), ignored.text


def test_metadata_at_the_limits_is_accepted(client: TestClient) -> None:
    response = post_model(client, metadata=nested(3))
    assert response.status_code == 202, response.text
    assert response.json()["metadata"] == json.loads(nested(3))


@pytest.mark.slow
@pytest.mark.parametrize(
    ("body", "pointer"),
    [
        ('{"name": "a\\u0000b"}', "/name"),
        ('{"name": "\\udfff"}', "/name"),
        ('{"metadata": {"x": NaN}}', "/metadata/x"),
        ('{"metadata": {"x": [1, -Infinity]}}', "/metadata/x/1"),
        ('{"metadata": ' + nested(900) + "}", "/metadata/a/a/a/a"),
        ('{"metadata": ' + nested(10_000) + "}", ""),
        ('{"metadata": {"k\\u0000": 1}}', "/metadata/k\x00"),
        ('{"metadata": {"big": "' + "v" * 2000 + '"}}', "/metadata"),
    ],
)
def test_bad_patches_are_422_with_a_pointer(client: TestClient, body: str, pointer: str) -> None:
    model = post_model(client, name="kept").json()
    assert_invalid(patch_model(client, model["id"], body), pointer)
    assert client.get(f"/v1/models/{model['id']}").json()["name"] == "kept"


def test_metadata_null_is_refused_as_the_schema_says(client: TestClient) -> None:
    model = post_model(client, metadata='{"a": 1}').json()
    assert_invalid(patch_model(client, model["id"], '{"metadata": null}'), "/metadata")
    patch_schema = client.get("/openapi.json").json()["components"]["schemas"]["ModelPatch"]
    assert patch_schema["properties"]["metadata"]["type"] == "object"  # not nullable


@pytest.mark.slow
@pytest.mark.parametrize(
    ("path", "pointer"),
    [
        ("/v1/models?external_id=a%00b", "/query/external_id"),
        ("/v1/models?cursor=%00", "/query/cursor"),
        ("/v1/models?external_id=%ff%fe", "/query/external_id"),
        ("/v1/models?external_id=" + "x" * 501, "/query/external_id"),
        ("/v1/models/00000000-0000-0000-0000-000000000000/similar?metadata.a=%00",
         "/query/metadata.a"),
        # No parameter is a list: the framework would keep the last value, unseen.
        ("/v1/models?limit=5&limit=50", "/query/limit"),
        ("/v1/models/00000000-0000-0000-0000-000000000000/similar?metadata.a=x&metadata.a=y",
         "/query/metadata.a"),
    ],
)
def test_bad_query_parameters_are_422_with_a_pointer(
    client: TestClient, path: str, pointer: str
) -> None:
    assert_invalid(client.get(path), pointer)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("path", "items", "past_the_end"),
    [
        ("/v1/models", "items", "1-" + "0" * 32),  # 1 µs after the epoch: nothing older
        ("/v1/jobs", "items", "1-" + "f" * 32),
        ("/v1/duplicates", "groups", "{report}-999999999"),  # past a stored report's end
    ],
)
def test_one_cursor_rule_on_every_paged_route(
    client: TestClient, path: str, items: str, past_the_end: str
) -> None:
    """Empty is the first page; every cursor the documented pattern admits is a page;
    anything else is 422 invalid-cursor."""
    post_model(client)
    if path == "/v1/duplicates":  # its pages are those of a stored report
        past_the_end = past_the_end.format(report=uuid.UUID(stored_duplicates(client)["id"]).hex)
    document = client.get("/openapi.json").json()
    (cursor,) = [p for p in document["paths"][path]["get"]["parameters"] if p["name"] == "cursor"]
    first = client.get(path, params={"cursor": ""})
    assert first.status_code == 200, first.text
    unpaged = client.get(path).json()[items]
    assert len(first.json()[items]) == len(unpaged) and (path == "/v1/duplicates" or unpaged)
    assert re.fullmatch(cursor["schema"]["pattern"], past_the_end)
    past = client.get(path, params={"cursor": past_the_end})
    assert past.status_code == 200, past.text
    assert past.json()[items] == [] and past.json()["next_cursor"] is None
    for garbage in ("garbage!", "-1", "1-" + "0" * 31, "1-" + "0" * 32 + "\n"):
        assert not re.fullmatch(cursor["schema"]["pattern"], garbage)
        refused = client.get(path, params={"cursor": garbage})
        assert refused.status_code == 422, (garbage, refused.text)
        assert refused.json()["type"] == "urn:shapesearch:problem:invalid-cursor"


def test_the_title_describes_the_type_and_413_names_the_setting(database_url: str) -> None:
    settings = make_settings(database_url, max_upload_bytes=1000)
    with TestClient(create_app(settings), raise_server_exceptions=False) as client:
        big = client.post(
            "/v1/models", files={"file": ("cube.stl", CUBE, "application/octet-stream")}
        )
        assert big.status_code == 413
        body = big.json()
        assert body["type"] == "urn:shapesearch:problem:too-large"
        assert "1000 bytes" in body["detail"] and "SHAPESEARCH_MAX_UPLOAD_BYTES" in body["detail"]
        assert body["title"] == "Too large"
        invalid = client.get("/v1/models", params={"limit": 0}).json()
        shape = client.post(
            "/v1/models", files={"file": ("x.stl", b"solid x\nendsolid", "text/plain")}
        ).json()
        assert invalid["status"] == shape["status"] == 422
        # RFC 9457: one title per type (the catalogue's), not per status.
        assert invalid["type"] != shape["type"]
        assert (invalid["title"], shape["title"]) == ("Invalid request", "Empty file")
        assert invalid["pointer"] == "/query/limit"
