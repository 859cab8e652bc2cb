"""The OpenAPI document, made to say exactly what the service does.

FastAPI derives most of the schema from the routes; three facts it cannot know are added
here, once, for every operation:

* the API key is optional in the document (``security: [{HTTPBearer: []}, {}]``): an open
  service (no key created yet) accepts requests without one;
* a malformed multipart form or JSON body is answered 400 (problem+json);
* an operation with a body may answer 413 when it is larger than the upload limit (the
  limit is enforced before routing);
* links from the model a POST /v1/models creates to the operations on it (its ``id``), so
  that clients and schema-driven tools can follow them.
"""

from __future__ import annotations

import json
from typing import Any

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi

from app.api.problems import PROBLEM_SCHEMA, problem_responses

__all__ = ["install_openapi"]


def _complete(operation: dict[str, Any]) -> None:
    if operation.get("security"):
        operation["security"] = [*operation["security"], {}]
    responses = operation.setdefault("responses", {})
    if "requestBody" in operation:
        for status, response in problem_responses(400, 413).items():
            responses.setdefault(str(status), response)
    # FastAPI documents its parameter validation as application/json; the service answers
    # every refusal as problem+json (app/api/problems.py).
    if "application/json" in responses.get("422", {}).get("content", {}):
        responses["422"] = problem_responses(422)[422]


def _link_created_models(paths: dict[str, Any]) -> None:
    created = paths.get("/v1/models", {}).get("post", {}).get("responses", {}).get("202")
    if created is None:
        return
    links = created.setdefault("links", {})
    for path, operations in paths.items():
        if not path.startswith("/v1/models/{model_id}"):
            continue
        for operation in operations.values():
            links[operation["operationId"]] = {
                "operationId": operation["operationId"],
                "parameters": {"model_id": "$response.body#/id"},
            }


def install_openapi(app: FastAPI) -> None:
    """Replace ``app.openapi`` with the completed document (built once, then cached)."""

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            schema = get_openapi(
                title=app.title,
                version=app.version,
                summary=app.summary,
                description=app.description,
                routes=app.routes,
            )
            for path in schema.get("paths", {}).values():
                for operation in path.values():
                    _complete(operation)
            _link_created_models(schema.get("paths", {}))
            schemas = schema.setdefault("components", {}).setdefault("schemas", {})
            schemas["Problem"] = PROBLEM_SCHEMA
            # FastAPI's own 422 body is never answered (every 422 is a Problem): drop it.
            for unused in ("HTTPValidationError", "ValidationError"):
                if f"#/components/schemas/{unused}" not in json.dumps(
                    {k: v for k, v in schema.items() if k != "components"}
                ):
                    schemas.pop(unused, None)
            app.openapi_schema = schema
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
