"""The OpenAPI document, made to say exactly what the service does.

FastAPI derives most of the schema from the routes; the facts it cannot know are added
here, once, for every operation:

* the API key is optional in the document (``security: [{HTTPBearer: []}, {}]``): an open
  service (no key created yet) accepts requests without one;
* a malformed multipart form or JSON body is answered 400 (problem+json);
* an operation with a body may answer 413 when it is larger than the upload limit (the
  limit is enforced before routing);
* the text rule of ``app.api.inputs`` (at most ``max_text_length`` characters, no NUL) on
  every string a client sends that has no pattern, format or enum of its own: query and
  path parameters, form fields, JSON body fields;
* parameters and form fields are never null (leaving one out is); a file part is
  binary, non-empty and named with an extension the service reads (the extension tells
  the format), and a JSON form field (``contentMediaType: application/json``, e.g.
  ``metadata``) is an object part sent as application/json;
* the shared components: ``Problem`` and the metadata filters (``app.api.search_params``);
* links from the model a POST /v1/models creates to the operations on it (its ``id``), so
  that clients and schema-driven tools can follow them.

What JSON Schema cannot say (whether a file's content is a readable shape, whether a
webhook host resolves to a public address) is said per operation, in its 415/422 entries.
"""

from __future__ import annotations

import copy
import json
from typing import Any

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi

from app.api.inputs import InputLimits
from app.api.problems import PROBLEM_SCHEMA, problem_responses
from app.api.search_params import FILTER_SCHEMAS
from core.io import FILE_EXTENSIONS

__all__ = ["install_openapi"]

_NO_NUL = r"^[^\x00]*$"
_JSON = "application/json"
_BINARY = "application/octet-stream"
# An example file name for tools that need one (schemathesis sends it); any name with one of
# FILE_EXTENSIONS is read, its extension compared case-insensitively.
_EXAMPLE_FILE_NAME = "part.stl"


# Methods that store something, or spool a request body to disk: a full disk refuses them.
_WRITES = frozenset({"post", "put", "patch", "delete"})


def _complete(path: str, method: str, operation: dict[str, Any]) -> None:
    if operation.get("security"):
        operation["security"] = [*operation["security"], {}]
    responses = operation.setdefault("responses", {})
    if "requestBody" in operation:
        for status, response in problem_responses(400, 413).items():
            responses.setdefault(str(status), response)
    if method in _WRITES:
        responses.setdefault("507", problem_responses(507)[507])
    if path.startswith("/v1/"):  # every call of the API reads the database
        responses.setdefault("503", problem_responses(503)[503])
    # FastAPI documents its parameter validation as application/json; the service answers
    # every refusal as problem+json (app/api/problems.py).
    if _JSON in responses.get("422", {}).get("content", {}):
        responses["422"] = problem_responses(422)[422]


def _text(schema: dict[str, Any], limits: InputLimits) -> None:
    """Add the text rule to a string schema (in place) unless it has its own constraint
    (a format, enum or pattern: those are stricter, and the server checks them)."""
    if schema.get("type") == "string" and not {"format", "enum", "pattern", "const",
                                               "contentMediaType"} & schema.keys():
        schema["pattern"] = _NO_NUL
        schema.setdefault("maxLength", limits.max_text_length)
    for branch in schema.get("anyOf", []):
        _text(branch, limits)


def _without_null(schema: dict[str, Any]) -> dict[str, Any]:
    """A parameter's or a form field's schema without its null alternative: neither can be
    null on the wire (leaving it out is)."""
    branches = [b for b in schema.get("anyOf", []) if b.get("type") != "null"]
    if len(branches) != 1 or len(schema["anyOf"]) == 1:
        return schema
    rest = {key: value for key, value in schema.items() if key != "anyOf"}
    return {**branches[0], **rest}


def _file_part(schema: dict[str, Any]) -> dict[str, Any]:
    """A file part: ``format: binary`` (the spelling generators read), at least one byte,
    and the name that tells the format."""
    # JSON Schema patterns have no case-insensitive flag: [sS][tT][lL].
    extensions = "|".join(
        "".join(f"[{c}{c.upper()}]" if c.isalpha() else c for c in extension)
        for extension in FILE_EXTENSIONS
    )
    disposition = {
        "description": "The file name's extension tells the format (case-insensitive): "
        + ", ".join(f".{e}" for e in FILE_EXTENSIONS) + ".",
        "schema": {"type": "string", "pattern": rf'filename="[^"]*\.({extensions})"'},
        "example": f'form-data; name="file"; filename="{_EXAMPLE_FILE_NAME}"',
    }
    schema.update({"format": "binary", "minLength": 1})
    return {"headers": {"Content-Disposition": disposition}}


def _complete_form(body: dict[str, Any], schemas: dict[str, Any], limits: InputLimits) -> None:
    """State the form fields of a multipart body as they travel (module docstring)."""
    media = body.get("content", {}).get("multipart/form-data")
    if media is None:
        return
    ref = media["schema"].get("$ref", "")
    form = schemas[ref.rsplit("/", 1)[-1]] if ref else media["schema"]
    encoding = media.setdefault("encoding", {})
    for name, field in list(form.get("properties", {}).items()):
        field = form["properties"][name] = _without_null(field)
        if field.get("contentMediaType") == _BINARY:
            encoding[name] = _file_part(field)
        elif field.get("contentMediaType") == _JSON:
            content = field.pop("contentSchema", {})
            del field["contentMediaType"]
            field.update({**content, "additionalProperties": True})
            encoding[name] = {"contentType": _JSON}
        else:
            _text(field, limits)
    if not encoding:
        del media["encoding"]


def _complete_inputs(
    operation: dict[str, Any], schemas: dict[str, Any], limits: InputLimits
) -> None:
    for parameter in operation.get("parameters", []):
        parameter["schema"] = _without_null(parameter["schema"])
        if parameter["in"] in ("query", "path"):
            _text(parameter["schema"], limits)
    body = operation.get("requestBody")
    if body is not None:
        _complete_form(body, schemas, limits)


def _complete_json_bodies(paths: dict[str, Any], schemas: dict[str, Any],
                          limits: InputLimits) -> None:
    """The text rule on the string fields of every JSON request body."""
    for operations in paths.values():
        for operation in operations.values():
            content = operation.get("requestBody", {}).get("content", {})
            ref = content.get(_JSON, {}).get("schema", {}).get("$ref")
            if ref is None:
                continue
            for field in schemas[ref.rsplit("/", 1)[-1]].get("properties", {}).values():
                _text(field, limits)


def _complete_filters(schemas: dict[str, Any], limits: InputLimits) -> None:
    """The filter objects' keys and values are query parameter names and values."""
    for name in FILTER_SCHEMAS:
        schemas[name]["propertyNames"].setdefault("maxLength", limits.max_text_length)
        _text(schemas[name]["additionalProperties"], limits)


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


def install_openapi(app: FastAPI, limits: InputLimits) -> None:
    """Replace ``app.openapi`` with the completed document (built once, then cached);
    ``limits`` are the service's input limits, stated in the document."""

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            schema = get_openapi(
                title=app.title,
                version=app.version,
                summary=app.summary,
                description=app.description,
                routes=app.routes,
            )
            paths = schema.get("paths", {})
            schemas = schema.setdefault("components", {}).setdefault("schemas", {})
            # Copies: the document is completed in place, the shared definitions stay as
            # they are.
            schemas["Problem"] = copy.deepcopy(PROBLEM_SCHEMA)
            schemas.update(copy.deepcopy(FILTER_SCHEMAS))
            for path, operations in paths.items():
                for method, operation in operations.items():
                    _complete(path, method, operation)
                    _complete_inputs(operation, schemas, limits)
            _complete_json_bodies(paths, schemas, limits)
            _complete_filters(schemas, limits)
            _link_created_models(paths)
            # FastAPI's own 422 body is never answered (every 422 is a Problem): drop it.
            for unused in ("HTTPValidationError", "ValidationError"):
                if f"#/components/schemas/{unused}" not in json.dumps(
                    {k: v for k, v in schema.items() if k != "components"}
                ):
                    schemas.pop(unused, None)
            app.openapi_schema = schema
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
