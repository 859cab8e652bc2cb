"""Request and response examples of every /v1 call, added to the OpenAPI document.

Kept apart from the routes so that the routes stay readable and the examples can be read
(and tested against the schemas, tests/test_examples.py) in one place. ``install_examples``
wraps ``app.openapi``: the generated document gets ``examples`` on the request bodies and on
every JSON and problem+json response listed in ``EXAMPLES``.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from fastapi import FastAPI

from app.api.inputs import invalid_input
from app.api.limits import too_large_problem
from app.api.problems import (
    PROBLEM_JSON,
    Problem,
    database_unavailable_problem,
    problem_response,
    storage_full_problem,
)
from app.api.uploads import out_of_memory_problem
from app.problems import problem
from core.cutoff import CutoffRecord
from core.io import SUPPORTED_FORMATS

__all__ = ["EXAMPLES", "install_examples"]

_ID = "3f0c9a52-8d1e-4b7a-9c61-2f5e8b7d4a10"
_ID2 = "b2d4e6f8-1a3c-4e5f-8a7b-9c0d1e2f3a4b"
_JOB = "7e6d5c4b-3a29-4817-a6b5-c4d3e2f1a0b9"
_JOB2 = "5a4b3c2d-1e0f-4a9b-8c7d-6e5f4a3b2c1d"
_JOB3 = "2c3d4e5f-6a7b-4c8d-9e0f-1a2b3c4d5e6f"
_REPORT = "8e9f0a1b-2c3d-4e5f-a6b7-c8d9e0f1a2b3"
_HOOK = "c1d2e3f4-a5b6-4c7d-8e9f-0a1b2c3d4e5f"
_DELIVERY = "0f1e2d3c-4b5a-4968-8776-a5b4c3d2e1f0"
_REVISION = "9d8c7b6a-5f4e-4d3c-b2a1-0f9e8d7c6b5a"
_REVISION2 = "6b5a4f3e-2d1c-4b0a-9f8e-7d6c5b4a3f2e"
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
_CUTOFF = CutoffRecord(
    mode="adaptive", n=191, solver_calls=3, predicted=[186],
    xi=1e-10, t=0.01, seed=50, n_min=80, n_max=500, margin=10,
    prediction=None, prediction_held=None, features=[8.006, 0.338, 0.707, 0.512],
).to_json()

MODEL_QUEUED: dict[str, Any] = {
    "id": _ID,
    "external_id": "PN-1001",
    "name": "Angle block",
    "metadata": {"material": "steel"},
    "status": "queued",
    "error": None,
    "file": _FILE,
    "n_points": None,
    "size": None,
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
    "size": {"length": 34.34, "width": 34.0, "height": 25.4, "area": 6056.3, "volume": 18771.9,
             "units": "mm"},
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
    "error": problem(
        "degenerate",
        "all points lie on a single line (or at one point), so the shape has no surface to "
        "describe: upload a part with extent in at least two directions",
    ),
}
_SUMMARY2 = {"id": _ID2, "external_id": "PN-1002", "name": "Feature block",
             "metadata": {"material": "steel"},
             "size": {"length": 127.0, "width": 63.5, "height": 34.93, "area": 34727.2,
                      "volume": 190543.2, "units": "mm"}}
_SIMILAR_RESULTS = [{"model": _SUMMARY2, "distance": 0.4176, "score": 0.9564,
                     "calibrated_score": 0.938, "likeness": "different kind"}]
_SUMMARY = {"id": _ID, "external_id": "PN-1001", "name": "Angle block",
            "metadata": {"material": "steel"},
            "size": {"length": 34.34, "width": 34.0, "height": 25.4, "area": 6056.3,
                     "volume": 18771.9, "units": "mm"}}
_ID3 = "d4e5f6a7-b8c9-4dae-8f01-2a3b4c5d6e7f"
_SUMMARY3 = {**_SUMMARY, "id": _ID3, "external_id": "PN-1001-B", "name": "Angle block, rev B"}
# GET /v1/models/{id}/compare/{other_id}?points=2: a revision with one end 2 mm longer.
_COMPARED = {
    "model": _SUMMARY,
    "other": _SUMMARY3,
    "units": "mm",
    "alignment": {
        "rotation": [[0.99998, -0.00412, 0.00503], [0.00411, 0.99999, 0.00197],
                     [-0.00504, -0.00195, 0.99999]],
        "translation": [0.0412, -0.0187, 0.0093],
        "scale": 1.0,
        "candidates": 24,
    },
    "tolerance": 0.5393,
    "model_to_other": {"rms": 0.2214, "mean": 0.1071, "p95": 0.4418, "max": 1.2206,
                       "within": 0.9623},
    "other_to_model": {"rms": 0.4127, "mean": 0.1693, "p95": 1.1734, "max": 1.9815,
                       "within": 0.9047},
    "size_ratios": [1.0581, 1.0006, 0.9997],
    "extents": {"model": [34.34, 34.0, 25.4], "other": [36.335, 34.02, 25.392]},
    "points_source": {"model": "sample", "other": "sample"},
    "points": {
        "model": {"positions": [[12.7, -4.318, 25.4], [-17.17, 9.906, 3.81]],
                  "deviations": [0.0213, 0.0871]},
        "other": {"positions": [[19.152, 2.118, 12.7], [-6.35, -17.0, 8.89]],
                  "deviations": [1.9118, 0.0302]},
    },
}
# The first result of POST /v1/search?explain=true: a single view of PN-1001 placed on it.
_EXPLANATION = {
    "alignment": {
        "rotation": [[0.3122, -0.9011, 0.3011], [0.9452, 0.3212, -0.0583],
                     [-0.0442, 0.3035, 0.9518]],
        "translation": [1.207, -0.331, 4.912],
        "scale": 0.99713,
        "candidates": 140,
    },
    "rms": 0.2377,
    "coverage": 0.4817,
    "tolerance": 0.5393,
    "view": None,
    "points_source": "sample",
    "points": None,
}


def _raised(problem: Problem) -> dict[str, Any]:
    """The problem+json body the service answers for ``problem`` (built by
    app/api/problems.py, so the type and the title are the service's own)."""
    body: dict[str, Any] = json.loads(bytes(problem_response(problem.record).body))
    return body


def _problem(kind: str, detail: str, **extra: Any) -> dict[str, Any]:
    return _raised(Problem(kind, detail, **extra))


def _validation(where: str, field: str, message: str, kind: str) -> dict[str, Any]:
    """FastAPI's refusal of one field (app/api/problems.py's validation handler)."""
    pointer = f"/{where}/{field}" if where != "body" else f"/{field}"
    return _problem("validation-error", f"{where}.{field}: {message}", pointer=pointer,
                    errors=[{"loc": [where, field], "msg": message, "type": kind,
                             "pointer": pointer}])


_UNAUTHORIZED = _problem("unauthorized",
                         "This service needs an API key: Authorization: Bearer KEY.")
_NOT_FOUND = _problem("model-not-found", f"There is no model {_ID}.")
_NOT_READY = _problem("model-not-ready",
                      f"Model {_ID} is processing; similarity needs a ready model.",
                      model_status="processing")
_TOO_LARGE = _raised(too_large_problem(67108864))
_OUT_OF_MEMORY = _raised(out_of_memory_problem())
_STORAGE_FULL = _raised(storage_full_problem())
_DATABASE_UNAVAILABLE = _raised(database_unavailable_problem())
# FastAPI's refusal of a body it cannot parse (app/api/problems.py turns it into problem+json).
_MALFORMED = problem("malformed-body", "Invalid multipart data.")
_UNKNOWN_FORMAT = _problem("unknown-format",
                           "could not tell the format of 'drawing.docx': upload one of "
                           f"{', '.join('.' + f for f in SUPPORTED_FORMATS)} (the file name's "
                           "extension tells the format)",
                           reason="unknown_format")
_TOO_FEW_POINTS = _problem("too-few-points",
                           "the shape has only 5 distinct points: upload a point cloud or mesh "
                           "with at least 100 distinct points", reason="too_few_points")
_INVALID_CURSOR = _problem("invalid-cursor",
                           "cursor is not valid; pass next_cursor unchanged.")
_WEBHOOK_NOT_FOUND = _problem("webhook-not-found", f"There is no webhook {_HOOK}.")
_JOB_NOT_FOUND = _problem("job-not-found", f"There is no job {_JOB}.")
_DELIVERY_NOT_FOUND = _problem("delivery-not-found",
                               f"The webhook {_HOOK} has no delivery {_DELIVERY}.")
_NEW_FILE = {
    "filename": "angle_block_rev_b.STL",
    "size": 36112,
    "sha256": "e3b7a41c9d2f8065b1c4d7e0a9f3b6c8d2e5f1a4b7c0d3e6f9a2b5c8d1e4f7a0",
    "format": "stl",
}
_JOB_DONE = {"id": _JOB, "kind": "describe", "model_id": _ID, "status": "done",
             "background": False, "attempts": 1, "last_error": None, "leased_until": None,
             "created_at": "2026-11-22T04:24:35.955773Z",
             "updated_at": "2026-11-22T04:24:38.120417Z"}
_JOB_QUEUED = {**_JOB_DONE, "id": _JOB2, "kind": "redescribe", "status": "queued",
               "attempts": 0, "created_at": "2026-11-23T09:12:05.310442Z",
               "updated_at": "2026-11-23T09:12:05.310442Z"}
_JOB_DUPLICATES = {**_JOB_DONE, "id": _JOB3, "kind": "duplicates", "model_id": None,
                   "status": "queued", "attempts": 0,
                   "created_at": "2026-11-24T02:00:38.016921Z",
                   "updated_at": "2026-11-24T02:00:38.016921Z"}


def _job_summary(job: dict[str, Any]) -> dict[str, Any]:
    """The ``job`` a model resource shows (JobSummary)."""
    return {key: job[key] for key in ("id", "status", "attempts", "created_at", "updated_at")}


# PUT /v1/models/by-external-id/PN-1001 with a new file: the model keeps its id and its
# previous descriptor (still searchable) while the job describes the new revision.
MODEL_REVISED: dict[str, Any] = {
    **MODEL_READY,
    "name": "Angle block, rev B",
    "updated_at": "2026-11-23T09:12:05.310442Z",
    "job": _job_summary(_JOB_QUEUED),
}
_WEBHOOK = {"id": _HOOK, "url": "https://plm.example.com/hooks/shapesearch",
            "events": ["model.failed", "model.ready"],
            "created_at": "2026-11-22T04:20:11.402918Z"}
_UPSERT_FORM = {"file": "(the bytes of angle_block_rev_b.STL)", "name": "Angle block, rev B",
                "metadata": {"material": "steel"}}
_UPLOAD_FORM = {"file": "(the bytes of angle_block.STL)", "external_id": "PN-1001",
                "name": "Angle block", "metadata": {"material": "steel"}}

# (method, path) -> {"request": {media type: value}, "responses": {status: value}}
EXAMPLES: dict[tuple[str, str], dict[str, Any]] = {
    ("post", "/v1/models"): {
        "request": {"multipart/form-data": _UPLOAD_FORM},
        "responses": {
            202: MODEL_QUEUED,
            401: _UNAUTHORIZED,
            409: _problem("duplicate-external-id",
                          f"external_id 'PN-1001' is already used by model {_ID}.",
                          existing_id=_ID),
            413: _TOO_LARGE,
            415: _UNKNOWN_FORMAT,
            422: _TOO_FEW_POINTS,
            503: _OUT_OF_MEMORY,
        },
    },
    ("get", "/v1/models"): {
        "responses": {
            200: {"items": [MODEL_READY, MODEL_FAILED], "next_cursor": None},
            401: _UNAUTHORIZED,
            422: _INVALID_CURSOR,
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
            422: _validation("query", "mode", "Input should be 'shape' or 'scan'",
                             "literal_error"),
        },
    },
    ("get", "/v1/models/{model_id}/compare/{other_id}"): {
        "responses": {
            200: _COMPARED,
            401: _UNAUTHORIZED,
            404: _NOT_FOUND,
            409: {**_NOT_READY, "detail": f"Model {_ID} is processing; a comparison needs two "
                  "ready models."},
            422: _validation("query", "tolerance", "Input should be greater than 0",
                             "greater_than"),
            503: _problem("busy", "The comparison could not be computed now: 2 comparisons "
                          "are being computed already; retry in 1 s."),
        },
    },
    ("get", "/v1/models/{model_id}/parts"): {
        "responses": {
            200: {"assembly_id": _ID3, "parts": [
                {"model": _SUMMARY, "count": 2, "placements": [
                    [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
                     0.0, 0.0, 0.0, 1.0],
                    [1.0, 0.0, 0.0, 60.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
                     0.0, 0.0, 0.0, 1.0]]},
                {"model": _SUMMARY2, "count": 1, "placements": [
                    [0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 40.0, 0.0, 0.0, 1.0, 25.4,
                     0.0, 0.0, 0.0, 1.0]]},
            ]},
            401: _UNAUTHORIZED,
            404: _NOT_FOUND,
        },
    },
    ("get", "/v1/models/{model_id}/where-used"): {
        "responses": {
            200: {"model_id": _ID, "assemblies": [
                {"assembly": {**_SUMMARY3, "external_id": "ASM-200", "name": "Fixture plate",
                              "size": None},
                 "count": 2, "parts": [_ID]},
            ]},
            401: _UNAUTHORIZED,
            404: _NOT_FOUND,
        },
    },
    ("get", "/v1/models/{model_id}/parts/points"): {
        "responses": {
            200: {"assembly_id": _ID, "part_ids": [_ID2, _ID3],
                  "points": [[12.5, 0.0, 2.5], [60.0, 58.1, 4.2], [71.3, -3.9, 5.0]],
                  "labels": [0, 1, 0]},
            401: _UNAUTHORIZED,
            404: _NOT_FOUND,
            409: {**_NOT_READY, "detail": f"Model {_ID} is processing; its points come with "
                  "its describe.", "model_status": "processing"},
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
                          "descriptor_version": _VERSION, "format": "ply",
                          "size": {"length": 36.24, "width": 35.55, "height": 25.5,
                                   "area": 6283.8, "volume": None, "units": "mm"}},
                "results": [
                    {"model": _SUMMARY, "distance": 0.2449, "score": 0.985,
                     "calibrated_score": 0.9957, "likeness": "copy",
                     "explanation": _EXPLANATION},
                    *_SIMILAR_RESULTS,
                ],
            },
            401: _UNAUTHORIZED,
            413: _TOO_LARGE,
            415: _UNKNOWN_FORMAT,
            422: _TOO_FEW_POINTS,
            503: _problem("solver-error",
                          "The shape could not be described this time: the eigensolver did "
                          "not converge."),
        },
    },
    ("get", "/v1/jobs/{job_id}"): {
        "responses": {
            200: _JOB_DONE,
            401: _UNAUTHORIZED,
            404: _JOB_NOT_FOUND,
        },
    },
    ("get", "/v1/stats/cutoff"): {
        "responses": {
            200: {
                "fixed_n": 300,
                "ready_models": 2,
                "mean_n": 179.5,
                "models": [
                    {"id": _ID2, "external_id": "PN-1002", "name": "Feature block",
                     "n_points": 3120,
                     "cutoff": {**_CUTOFF, "n": 168, "solver_calls": 2, "predicted": []}},
                    {"id": _ID, "external_id": "PN-1001", "name": "Angle block",
                     "n_points": 4767, "cutoff": _CUTOFF},
                ],
                "solver_calls": [{"solver_calls": 2, "models": 1},
                                 {"solver_calls": 3, "models": 1}],
            },
            401: _UNAUTHORIZED,
        },
    },
    ("put", "/v1/models/by-external-id/{external_id}"): {
        "request": {"multipart/form-data": _UPSERT_FORM},
        "responses": {
            # The same file again: only name and metadata change, no job.
            200: {**MODEL_READY, "name": "Angle block, rev B",
                  "updated_at": "2026-11-23T09:12:05.310442Z", "job": _job_summary(_JOB_DONE)},
            201: {**MODEL_QUEUED,
                  "job": _job_summary({**_JOB_DONE, "status": "queued", "attempts": 0,
                                       "updated_at": MODEL_QUEUED["created_at"]})},
            202: MODEL_REVISED,
            401: _UNAUTHORIZED,
            413: _TOO_LARGE,
            415: _UNKNOWN_FORMAT,
            422: _raised(invalid_input("/metadata", "must be a JSON object")),
            503: _OUT_OF_MEMORY,
        },
    },
    ("get", "/v1/models/{model_id}/revisions"): {
        "responses": {
            200: {"items": [
                {"id": _REVISION2, "number": 2, "status": "pending", "file": _NEW_FILE,
                 "created_at": "2026-11-23T09:12:05.310442Z"},
                {"id": _REVISION, "number": 1, "status": "current", "file": _FILE,
                 "created_at": "2026-11-22T04:24:35.955773Z"},
            ]},
            401: _UNAUTHORIZED,
            404: _NOT_FOUND,
        },
    },
    ("post", "/v1/models/{model_id}/redescribe"): {
        "responses": {202: _JOB_QUEUED, 401: _UNAUTHORIZED, 404: _NOT_FOUND},
    },
    ("get", "/v1/models/{model_id}/file"): {
        "responses": {401: _UNAUTHORIZED, 404: _NOT_FOUND},
    },
    ("get", "/v1/stats"): {
        "responses": {
            200: {
                "models": 3,
                "by_status": {"failed": 1, "ready": 2},
                "by_descriptor_version": {_VERSION: 2},
                "jobs_by_status": {"done": 2, "failed": 1},
                "current_descriptor_version": _VERSION,
                "engine_libraries": {
                    "numpy": "2.4.6", "scipy": "1.17.1", "trimesh": "5.2.0",
                    "robust-laplacian": "1.1.0", "qdldl": "0.1.9.post1",
                },
                "ready_without_size": 0,
            },
            401: _UNAUTHORIZED,
        },
    },
    ("post", "/v1/duplicates"): {
        "request": {"application/json": {"min_score": 0.98, "size_tolerance": 0.02}},
        "responses": {
            202: _JOB_DUPLICATES,
            401: _UNAUTHORIZED,
            422: _validation("body", "min_score", "Input should be less than or equal to 1",
                             "less_than_equal"),
        },
    },
    ("get", "/v1/duplicates"): {
        "responses": {
            200: {
                "id": _REPORT,
                "job_id": _JOB3,
                "descriptor_version": _VERSION,
                "min_score": 0.98,
                "size_tolerance": 0.02,
                "computed_at": "2026-11-24T02:00:41.207315Z",
                "models": 2,
                "group_count": 1,
                "exact": True,
                "stale": False,
                "groups": [{
                    "number": 1,
                    "size": 2,
                    "members": [
                        {"id": _ID, "external_id": "PN-1001", "name": "Angle block"},
                        {"id": _ID2, "external_id": "PN-1001-M", "name": "Angle block, mirrored"},
                    ],
                    "pairs": [{"a": _ID, "b": _ID2, "score": 0.9993}],
                }],
                "next_cursor": None,
            },
            401: _UNAUTHORIZED,
            404: _problem(
                "duplicates-report-not-found",
                f"There is no duplicates report with min_score=0.98, size_tolerance=0.02 and "
                f"descriptor_version={_VERSION} yet: POST /v1/duplicates with these "
                "parameters, then GET again once its job is done.",
            ),
            422: _validation("query", "min_score", "Input should be less than or equal to 1",
                             "less_than_equal"),
        },
    },
    ("get", "/v1/jobs"): {
        "responses": {
            200: {"items": [_JOB_QUEUED, _JOB_DONE], "next_cursor": None},
            401: _UNAUTHORIZED,
            422: _INVALID_CURSOR,
        },
    },
    ("post", "/v1/webhooks"): {
        "request": {"application/json": {"url": _WEBHOOK["url"],
                                          "events": ["model.ready", "model.failed"]}},
        "responses": {
            201: {**_WEBHOOK, "secret": "whsec_MfKQ9r8GKYqXnDsRmu1Z3aYq7vPXGx4f"},
            401: _UNAUTHORIZED,
            422: _problem("webhook-url-refused",
                          "Webhook URL refused: the host '10.0.0.12' resolves to the non-public "
                          "address 10.0.0.12; set SHAPESEARCH_WEBHOOK_ALLOW_PRIVATE=true to "
                          "allow private targets."),
        },
    },
    ("get", "/v1/webhooks"): {
        "responses": {200: {"items": [_WEBHOOK]}, 401: _UNAUTHORIZED},
    },
    ("get", "/v1/webhooks/{webhook_id}"): {
        "responses": {200: _WEBHOOK, 401: _UNAUTHORIZED, 404: _WEBHOOK_NOT_FOUND},
    },
    ("delete", "/v1/webhooks/{webhook_id}"): {
        "responses": {401: _UNAUTHORIZED, 404: _WEBHOOK_NOT_FOUND},
    },
    ("get", "/v1/webhooks/{webhook_id}/deliveries"): {
        "responses": {
            200: {"items": [{
                "id": _DELIVERY,
                "event_type": "model.ready",
                "status": "delivered",
                "attempts": [
                    {"attempt": 1, "status_code": 503, "error": None, "duration_ms": 41.7,
                     "created_at": "2026-11-22T04:24:38.402117Z"},
                    {"attempt": 2, "status_code": 200, "error": None, "duration_ms": 18.2,
                     "created_at": "2026-11-22T04:24:43.511930Z"},
                ],
                "payload": {"type": "model.ready", "timestamp": "2026-11-22T04:24:38.125003+00:00",
                            "data": {"model": MODEL_READY,
                                     "job": {"id": _JOB, "status": "done", "attempts": 1,
                                             "error": None}}},
                "next_attempt_at": None,
                "created_at": "2026-11-22T04:24:38.130552Z",
            }]},
            401: _UNAUTHORIZED,
            404: _WEBHOOK_NOT_FOUND,
        },
    },
    ("post", "/v1/webhooks/{webhook_id}/recover"): {
        "request": {"application/json": {"since": "2026-11-22T00:00:00Z"}},
        "responses": {
            202: {"requeued": 17},
            401: _UNAUTHORIZED,
            404: _WEBHOOK_NOT_FOUND,
            422: _validation("body", "since", "Input should be a valid datetime or date, "
                             "invalid character in year", "datetime_from_date_parsing"),
        },
    },
    ("post", "/v1/webhooks/{webhook_id}/deliveries/{delivery_id}/retry"): {
        "responses": {
            202: {
                "id": _DELIVERY,
                "event_type": "model.ready",
                "status": "pending",
                "attempts": [
                    {"attempt": 8, "status_code": None,
                     "error": "ConnectError: [Errno 111] Connection refused", "duration_ms": 2.3,
                     "created_at": "2026-11-22T04:35:13.402117Z"},
                ],
                "payload": {"type": "model.ready", "timestamp": "2026-11-22T04:24:38.125003+00:00",
                            "data": {"model": MODEL_READY}},
                "next_attempt_at": "2026-11-22T09:02:11.250611Z",
                "created_at": "2026-11-22T04:24:38.130552Z",
            },
            401: _UNAUTHORIZED,
            404: _DELIVERY_NOT_FOUND,
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
    _add_generic_refusals(document)
    return document


def _invalid_parameter(operation: dict[str, Any]) -> dict[str, Any]:
    """The 422 for an invalid value of the operation's first parameter."""
    parameters = operation.get("parameters") or [{"in": "body", "name": "file"}]
    where = {"path": "path", "query": "query", "header": "header"}.get(parameters[0]["in"], "body")
    return _validation(where, parameters[0]["name"], "Input is not valid", "value_error")


def _add_generic_refusals(document: dict[str, Any]) -> None:
    """Examples of the 400, 413, 422, 503 and 507 that app/api/openapi.py documents for every
    operation that can answer them, where the operation has no example of its own."""
    for operations in document["paths"].values():
        for operation in operations.values():
            refusals = {"400": _MALFORMED, "413": _TOO_LARGE, "422": _invalid_parameter(operation),
                        "503": _DATABASE_UNAVAILABLE, "507": _STORAGE_FULL}
            for status, value in refusals.items():
                response = operation.get("responses", {}).get(status, {})
                content = response.get("content", {}).get(PROBLEM_JSON)
                if content is not None and "examples" not in content:
                    _add(content, value)


def install_examples(app: FastAPI) -> None:
    """Make ``app.openapi()`` return the generated document with the examples."""
    generate: Callable[[], dict[str, Any]] = app.openapi

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            app.openapi_schema = add_examples(generate())
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
