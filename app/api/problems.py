"""RFC 9457 problem details for every error the API returns.

``Problem`` is raised by the routes; the handlers installed by ``install_problem_handlers``
also turn Starlette's HTTP errors (404 of unknown routes, 405, ...), FastAPI's validation
errors (422) and unexpected exceptions (500) into ``application/problem+json`` with
``type``, ``title``, ``status`` and ``detail``.

Types: ``about:blank`` when the status code says it all, otherwise
``urn:shapesearch:problem:<slug>`` (e.g. ``too-few-points``, ``duplicate-external-id``), one
slug per kind of error: every refused field is ``validation-error`` (with a JSON
``pointer``), every size limit ``too-large`` (naming the limit's setting). The title is the
status's phrase, one per status, whatever raised the error.
"""

from __future__ import annotations

import logging
from http import HTTPStatus
from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import compile_path

__all__ = [
    "PROBLEM_JSON",
    "Problem",
    "install_problem_handlers",
    "problem_response",
    "problem_responses",
    "problem_type",
]

PROBLEM_JSON = "application/problem+json"

log = logging.getLogger("shapesearch.api")


_MEANINGS = {
    400: "Malformed request body (multipart form or JSON)",
    401: "No or invalid API key",
    403: "Not allowed for this client",
    404: "No such model or job (for this tenant)",
    409: "Conflict with the current state",
    413: "Upload larger than the limit",
    415: "Unknown file format",
    422: "Invalid request or shape file",
    503: "Not ready, or the shape could not be described this time",
}


def problem_responses(*statuses: int) -> dict[int | str, dict[str, Any]]:
    """OpenAPI ``responses`` entries documenting problem+json bodies for ``statuses``."""
    schema = {
        "type": "object",
        "required": ["type", "title", "status", "detail"],
        "properties": {
            "type": {"type": "string"},
            "title": {"type": "string"},
            "status": {"type": "integer"},
            "detail": {"type": "string"},
        },
    }
    return {
        status: {"description": _MEANINGS[status], "content": {PROBLEM_JSON: {"schema": schema}}}
        for status in statuses
    }


def problem_type(slug: str) -> str:
    return f"urn:shapesearch:problem:{slug}"


class Problem(StarletteHTTPException):
    """An error response. A Starlette ``HTTPException`` so that it passes unchanged through
    FastAPI's request-body parsing (the upload size limit is raised from there)."""

    def __init__(
        self,
        status: int,
        detail: str,
        *,
        slug: str | None = None,
        title: str | None = None,
        headers: dict[str, str] | None = None,
        **extensions: Any,
    ) -> None:
        super().__init__(status_code=status, detail=detail, headers=headers)
        self.type = problem_type(slug) if slug else "about:blank"
        self.title = title or HTTPStatus(status).phrase
        self.extensions = extensions


def problem_response(
    status: int,
    detail: str,
    *,
    type: str = "about:blank",
    title: str | None = None,
    headers: dict[str, str] | None = None,
    **extensions: Any,
) -> JSONResponse:
    """The problem+json response. ``title`` is ignored: the title is the status's phrase, so
    that one status has one title (the ``type`` and ``detail`` say what happened)."""
    body = {
        "type": type,
        "title": HTTPStatus(status).phrase,
        "status": status,
        "detail": detail,
        **extensions,
    }
    return JSONResponse(
        jsonable_encoder(body), status_code=status, media_type=PROBLEM_JSON, headers=headers
    )


def _allowed_methods(request: Request) -> str:
    """Every method the API documents at this path (Starlette names only the methods of the
    first route that matched); HEAD comes with GET."""
    methods: set[str] = set()
    for template, operations in request.app.openapi().get("paths", {}).items():
        if compile_path(template)[0].match(request.url.path):
            methods |= {method.upper() for method in operations}
    if "GET" in methods:
        methods.add("HEAD")
    return ", ".join(sorted(methods))


async def _on_problem(request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, StarletteHTTPException)
    if exc.status_code == 405 and not isinstance(exc, Problem):
        exc.headers = {**(exc.headers or {}), "Allow": _allowed_methods(request)}
    if isinstance(exc, Problem):
        return problem_response(
            exc.status_code,
            str(exc.detail),
            type=exc.type,
            title=exc.title,
            headers=exc.headers,
            **exc.extensions,
        )
    if exc.status_code == 400 and isinstance(exc.__cause__, RecursionError):
        # FastAPI could not parse a JSON body because it is nested too deeply.
        return problem_response(
            422,
            "the JSON body is nested too deeply to be read",
            type=problem_type("validation-error"),
            pointer="",
            errors=[{"pointer": "", "detail": "nested too deeply"}],
        )
    detail = exc.detail if isinstance(exc.detail, str) else HTTPStatus(exc.status_code).phrase
    return problem_response(exc.status_code, detail, headers=exc.headers)


async def _on_validation(_request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, RequestValidationError)
    errors = [
        {
            "loc": list(error.get("loc", ())),
            "msg": error.get("msg", ""),
            "type": error.get("type"),
            "pointer": _pointer(error.get("loc", ())),
        }
        for error in exc.errors()
    ]
    detail = "; ".join(
        f"{'.'.join(str(part) for part in error['loc'])}: {error['msg']}" for error in errors
    )
    return problem_response(
        422,
        detail or "The request is not valid.",
        type=problem_type("validation-error"),
        pointer=errors[0]["pointer"] if errors else "",
        errors=errors,
    )


def _pointer(loc: Any) -> str:
    """JSON pointer of a FastAPI error location: ("body", "name") -> "/name",
    ("query", "k") -> "/query/k"."""
    parts = [str(part) for part in loc]
    if parts and parts[0] == "body":
        parts = parts[1:]
    return "".join("/" + part.replace("~", "~0").replace("/", "~1") for part in parts)


async def _on_unexpected(_request: Request, exc: Exception) -> JSONResponse:
    log.exception("unhandled error", exc_info=exc)
    return problem_response(500, "An unexpected error occurred; it has been logged.")


def install_problem_handlers(app: FastAPI) -> None:
    app.add_exception_handler(StarletteHTTPException, _on_problem)
    app.add_exception_handler(RequestValidationError, _on_validation)
    app.add_exception_handler(Exception, _on_unexpected)
