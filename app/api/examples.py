"""Request and response examples of every /v1 call, added to the OpenAPI document.

Kept apart from the routes so that the routes stay readable and the examples can be read
(and tested against the schemas, tests/test_examples.py) in one place. ``install_examples``
wraps ``app.openapi``: the generated document gets ``examples`` on the request bodies and on
every JSON and problem+json response listed in ``EXAMPLES``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from fastapi import FastAPI

__all__ = ["EXAMPLES", "install_examples"]

PROBLEM_JSON = "application/problem+json"

_ID = "3f0c9a52-8d1e-4b7a-9c61-2f5e8b7d4a10"
_ID2 = "b2d4e6f8-1a3c-4e5f-8a7b-9c0d1e2f3a4b"
_JOB = "7e6d5c4b-3a29-4817-a6b5-c4d3e2f1a0b9"
_VERSION = (
    "ss2;lap=robust;norm=area;pts=20000+sor;cut=adaptive(xi=1e-10,t=0.01,80-500);"
    "hkss=16[0.001,0.1]w0.2;bins=32[-2,2.5];wks=16[2,7.5]s0.733w1slope1;dna=30w0.2;7edb95adec"
)
_FILE = {
    "filename": "angle_block.STL",
    "size": 35284,
    "sha256": "9a4c5e0f3b1d7a26c8e4f0b2d6a8c1e3f5a7b9d0c2e4f6a8b0c1d3e5f7a9b2c4",
    "format": "stl",
}
_CUTOFF = {"mode": "adaptive", "n": 191, "solver_calls": 3, "xi": 1e-10, "t": 0.01,
           "n_min": 80, "n_max": 500}

MODEL_QUEUED: dict[str, Any] = {
    "id": _ID,
    "external_id": "PN-1001",
    "name": "Angle block",
    "metadata": {"material": "steel"},
    "status": "queued",
    "error": None,
    "file": _FILE,
    "n_points": None,
    "cutoff": None,
    "descriptor_version": None,
    "timings": None,
    "created_at": "2026-11-22T04:24:35.955773Z",
    "updated_at": "2026-11-22T04:24:35.955773Z",
}
MODEL_READY: dict[str, Any] = {
    **MODEL_QUEUED,
    "status": "ready",
    "n_points": 4767,
    "cutoff": _CUTOFF,
    "descriptor_version": _VERSION,
    "timings": {"load": 0.031, "laplacian": 0.42, "eigensolve": 1.333, "signature": 0.032,
                "descriptor": 0.026, "total": 1.851},
    "updated_at": "2026-11-22T04:24:38.120417Z",
}
MODEL_FAILED: dict[str, Any] = {
    **MODEL_QUEUED,
    "id": _ID2,
    "external_id": "PN-1003",
    "status": "failed",
    "error": {
        "type": "urn:shapesearch:problem:degenerate-shape",
        "title": "Degenerate shape",
        "detail": "All points lie on a line: a surface is needed.",
    },
}
_SUMMARY2 = {"id": _ID2, "external_id": "PN-1002", "name": "Feature block",
             "metadata": {"material": "steel"}}
_SIMILAR_RESULTS = [{"model": _SUMMARY2, "distance": 0.4176, "score": 0.9564}]


def _problem(status: int, slug: str, title: str, detail: str, **extra: Any) -> dict[str, Any]:
    return {"type": f"urn:shapesearch:problem:{slug}", "title": title, "status": status,
            "detail": detail, **extra}


def _validation(where: str, field: str, message: str, kind: str) -> dict[str, Any]:
    return _problem(422, "validation-error", "Invalid request", f"{where}.{field}: {message}",
                    errors=[{"loc": [where, field], "msg": message, "type": kind}])


_UNAUTHORIZED = _problem(401, "unauthorized", "Unauthorized",
                         "This service needs an API key: Authorization: Bearer KEY.")
_NOT_FOUND = _problem(404, "model-not-found", "Not Found", f"There is no model {_ID}.")
_NOT_READY = _problem(409, "model-not-ready", "Conflict",
                      f"Model {_ID} is processing; similarity needs a ready model.",
                      model_status="processing")
_TOO_LARGE = _problem(413, "too-large", "Content Too Large",
                      "The file is larger than the limit of 67108864 bytes.")
_UNKNOWN_FORMAT = _problem(415, "unknown-format", "Unknown format",
                           "could not tell the format of 'drawing.docx': upload one of .stl, "
                           ".obj, .off, .ply, .glb, .xyz, .txt, .csv, .pts, .pcd, .npy (the file "
                           "name's extension tells the format)", reason="unknown_format")
_TOO_FEW_POINTS = _problem(422, "too-few-points", "Too few points",
                           "the shape has only 5 distinct points: upload a point cloud or mesh "
                           "with at least 100 distinct points", reason="too_few_points")
_UPLOAD_FORM = {"file": "(the bytes of angle_block.STL)", "external_id": "PN-1001",
                "name": "Angle block", "metadata": '{"material": "steel"}'}

# (method, path) -> {"request": {media type: value}, "responses": {status: value}}
EXAMPLES: dict[tuple[str, str], dict[str, Any]] = {
    ("post", "/v1/models"): {
        "request": {"multipart/form-data": _UPLOAD_FORM},
        "responses": {
            202: MODEL_QUEUED,
            401: _UNAUTHORIZED,
            409: _problem(409, "duplicate-external-id", "Conflict",
                          f"external_id 'PN-1001' is already used by model {_ID}.",
                          existing_id=_ID),
            413: _TOO_LARGE,
            415: _UNKNOWN_FORMAT,
            422: _TOO_FEW_POINTS,
        },
    },
    ("get", "/v1/models"): {
        "responses": {
            200: {"items": [MODEL_READY, MODEL_FAILED], "next_cursor": None},
            401: _UNAUTHORIZED,
            422: _problem(422, "invalid-cursor", "Unprocessable Entity",
                          "cursor is not valid; pass next_cursor unchanged."),
        },
    },
    ("get", "/v1/models/{model_id}"): {
        "responses": {200: MODEL_READY, 401: _UNAUTHORIZED, 404: _NOT_FOUND},
    },
    ("patch", "/v1/models/{model_id}"): {
        "request": {"application/json": {"name": "Angle block, rev B",
                                          "metadata": {"material": "aluminium"}}},
        "responses": {
            200: {**MODEL_READY, "name": "Angle block, rev B",
                  "metadata": {"material": "aluminium"}},
            401: _UNAUTHORIZED,
            404: _NOT_FOUND,
            422: _validation("body", "metadata",
                             "Value error, metadata must be a JSON object; send {} to clear it",
                             "value_error"),
        },
    },
    ("delete", "/v1/models/{model_id}"): {
        "responses": {401: _UNAUTHORIZED, 404: _NOT_FOUND},
    },
    ("get", "/v1/models/{model_id}/similar"): {
        "responses": {
            200: {"query": {"model_id": _ID}, "results": _SIMILAR_RESULTS},
            401: _UNAUTHORIZED,
            404: _NOT_FOUND,
            409: _NOT_READY,
            422: _validation("query", "k", "Input should be less than or equal to 100",
                             "less_than_equal"),
        },
    },
    ("get", "/v1/models/{model_id}/preview"): {
        "responses": {
            401: _UNAUTHORIZED,
            404: _NOT_FOUND,
            409: {**_NOT_READY, "detail": f"Model {_ID} is queued; a preview needs a ready model.",
                  "model_status": "queued"},
        },
    },
    ("post", "/v1/search"): {
        "request": {"multipart/form-data": {"file": "(the bytes of angle_block_scan.ply)"}},
        "responses": {
            200: {
                "query": {"n_points": 7289, "cutoff": {**_CUTOFF, "n": 204},
                          "descriptor_version": _VERSION, "format": "ply"},
                "results": [
                    {"model": {"id": _ID, "external_id": "PN-1001", "name": "Angle block",
                               "metadata": {"material": "steel"}},
                     "distance": 0.2449, "score": 0.985},
                    *_SIMILAR_RESULTS,
                ],
            },
            401: _UNAUTHORIZED,
            413: _TOO_LARGE,
            415: _UNKNOWN_FORMAT,
            422: _TOO_FEW_POINTS,
            503: _problem(503, "solver-error", "Service Unavailable",
                          "The shape could not be described this time: the eigensolver did "
                          "not converge."),
        },
    },
    ("get", "/v1/jobs/{job_id}"): {
        "responses": {
            200: {"id": _JOB, "model_id": _ID, "status": "done", "attempts": 1,
                  "last_error": None, "leased_until": None,
                  "created_at": "2026-11-22T04:24:35.955773Z",
                  "updated_at": "2026-11-22T04:24:38.120417Z"},
            401: _UNAUTHORIZED,
            404: _problem(404, "job-not-found", "Not Found", f"There is no job {_JOB}."),
        },
    },
    ("get", "/v1/stats/cutoff"): {
        "responses": {
            200: {
                "fixed_n": 300,
                "models": [
                    {"id": _ID2, "external_id": "PN-1002", "name": "Feature block",
                     "n_points": 3120, "n": 168, "solver_calls": 2, "mode": "adaptive"},
                    {"id": _ID, "external_id": "PN-1001", "name": "Angle block",
                     "n_points": 4767, "n": 191, "solver_calls": 3, "mode": "adaptive"},
                ],
                "solver_calls": [{"solver_calls": 2, "models": 1},
                                 {"solver_calls": 3, "models": 1}],
            },
            401: _UNAUTHORIZED,
        },
    },
}


def _add(content: dict[str, Any], value: Any) -> None:
    content["examples"] = {"example": {"value": value}}


def add_examples(document: dict[str, Any]) -> dict[str, Any]:
    """Put ``EXAMPLES`` into an OpenAPI document (in place; also returned)."""
    for (method, path), example in EXAMPLES.items():
        operation = document["paths"][path][method]
        for media, value in example.get("request", {}).items():
            _add(operation["requestBody"]["content"][media], value)
        for status, value in example["responses"].items():
            content = operation["responses"][str(status)]["content"]
            media = PROBLEM_JSON if status >= 400 else "application/json"
            _add(content[media], value)
    return document


def install_examples(app: FastAPI) -> None:
    """Make ``app.openapi()`` return the generated document with the examples."""
    generate: Callable[[], dict[str, Any]] = app.openapi

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            app.openapi_schema = add_examples(generate())
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
