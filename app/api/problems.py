"""RFC 9457 problem details for every error the API returns.

``Problem(kind, detail)`` is raised by the routes, with its status, type and title from the
error catalogue (``app.problems``); the handlers installed by ``install_problem_handlers``
also turn the engine's errors (``core.errors``: an ``InvalidShapeError`` by its reason, a
``SolverError`` as ``solver-error``), Starlette's HTTP errors (404 of unknown routes, 405,
...), FastAPI's validation errors (422), full storage (507 ``storage-full``, however the
database driver or the upload's spooling reported it: ``app.storage``), a database
unavailable for a moment (503 ``database-unavailable``: ``app.db.errors``) and unexpected
exceptions (500) into ``application/problem+json``. Every refused field is
``validation-error`` (with a JSON ``pointer``), every size limit ``too-large`` (naming the
limit's setting).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from http import HTTPStatus
from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from sqlalchemy.exc import DBAPIError
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import compile_path

from app.db.errors import database_unavailable
from app.observability.logs import first_line
from app.problems import CATALOGUE, blank_problem, problem, reason_kind
from app.storage import storage_full
from core.errors import InvalidShapeError, SolverError

__all__ = [
    "PROBLEM_JSON",
    "Problem",
    "install_problem_handlers",
    "problem_response",
    "problem_responses",
    "PROBLEM_SCHEMA",
    "database_unavailable_problem",
    "storage_full_problem",
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
    503: "Not ready, busy, or the database unavailable for a moment: try again after "
    "Retry-After",
    507: "The service's storage is full: nothing was stored; try again after Retry-After",
}

# Seconds a client is asked to wait when storage is full: an operator has to free space.
STORAGE_FULL_RETRY_AFTER = 60
# ... and when the database was unavailable: the pool reconnects on the next request.
DATABASE_RETRY_AFTER = 1


#: The JSON Schema of every problem+json body: one component, ``#/components/schemas/Problem``,
#: that every 4xx/5xx response of the OpenAPI document references (``app.api.openapi``).
PROBLEM_SCHEMA: dict[str, Any] = {
    "title": "Problem",
    "description": "RFC 9457 problem details; a kind's extension members (pointer, errors, "
    "reason, existing_id, model_status, checks) come next to these.",
    "type": "object",
    "required": ["type", "title", "status", "detail"],
    "properties": {
        "type": {"type": "string", "description": "urn:shapesearch:problem:<kind>, or "
                 "about:blank when the status says it all."},
        "title": {"type": "string", "description": "The kind's title (one per type)."},
        "status": {"type": "integer"},
        "detail": {"type": "string"},
        # Extension members of some kinds.
        "pointer": {"type": "string", "description": "validation-error: a JSON pointer to "
                    "the refused field (/query/k, /metadata/a)."},
        "errors": {"type": "array", "items": {"type": "object"},
                   "description": "validation-error: every refused field."},
        "reason": {"type": "string", "description": "A refused shape file: the engine's "
                   "reason code (too_few_points, degenerate, ...)."},
        "limit": {"type": "integer", "description": "too-large: the limit, in bytes."},
        "existing_id": {"type": "string", "description": "duplicate-external-id: the "
                        "model that holds the external id."},
        "model_status": {"type": "string", "description": "model-not-ready: its status."},
        "checks": {"type": "object", "additionalProperties": {"type": "string"},
                   "description": "not-ready: every readiness check's state."},
    },
}
PROBLEM_REF = {"$ref": "#/components/schemas/Problem"}


def problem_responses(*statuses: int) -> dict[int | str, dict[str, Any]]:
    """OpenAPI ``responses`` entries documenting problem+json bodies for ``statuses``."""
    return {
        status: {
            "description": _MEANINGS[status],
            "content": {PROBLEM_JSON: {"schema": PROBLEM_REF}},
        }
        for status in statuses
    }


class Problem(StarletteHTTPException):
    """An error response of a catalogued ``kind`` (``app.problems.CATALOGUE``). A Starlette
    ``HTTPException`` so that it passes unchanged through FastAPI's request-body parsing
    (the upload size limit is raised from there)."""

    def __init__(
        self,
        kind: str,
        detail: str,
        *,
        headers: dict[str, str] | None = None,
        **extensions: Any,
    ) -> None:
        super().__init__(status_code=CATALOGUE[kind].status, detail=detail, headers=headers)
        self.record = problem(kind, detail, **extensions)


def problem_response(
    record: dict[str, Any], headers: Mapping[str, str] | None = None
) -> JSONResponse:
    """The problem+json response of a problem ``record`` (``app.problems.problem``)."""
    return JSONResponse(
        jsonable_encoder(record), status_code=record["status"], media_type=PROBLEM_JSON,
        headers=headers,
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
        return problem_response(exc.record, headers=exc.headers)
    if exc.status_code == 400 and exc.__cause__ is not None and storage_full(exc.__cause__):
        # FastAPI could not spool the upload to a temporary file: the disk is full.
        return _storage_full_response(exc.__cause__)
    if exc.status_code == 400 and isinstance(exc.__cause__, RecursionError):
        # FastAPI could not parse a JSON body because it is nested too deeply.
        return problem_response(problem(
            "validation-error", "the JSON body is nested too deeply to be read", pointer="",
            errors=[{"pointer": "", "detail": "nested too deeply"}],
        ))
    detail = exc.detail if isinstance(exc.detail, str) else HTTPStatus(exc.status_code).phrase
    if exc.status_code == 400:
        # Starlette's and FastAPI's only 400: the multipart form could not be parsed.
        return problem_response(problem("malformed-body", detail), headers=exc.headers)
    return problem_response(blank_problem(exc.status_code, detail), headers=exc.headers)


async def _on_invalid_shape(_request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, InvalidShapeError)
    return problem_response(problem(reason_kind(exc.reason), exc.message, reason=exc.reason))


async def _on_solver_error(_request: Request, exc: Exception) -> JSONResponse:
    return problem_response(
        problem("solver-error", f"The shape could not be described this time: {exc}")
    )


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
    return problem_response(problem(
        "validation-error",
        detail or "The request is not valid.",
        pointer=errors[0]["pointer"] if errors else "",
        errors=errors,
    ))


def _pointer(loc: Any) -> str:
    """JSON pointer of a FastAPI error location: ("body", "name") -> "/name",
    ("query", "k") -> "/query/k"."""
    parts = [str(part) for part in loc]
    if parts and parts[0] == "body":
        parts = parts[1:]
    return "".join("/" + part.replace("~", "~0").replace("/", "~1") for part in parts)


async def _on_database_error(_request: Request, exc: Exception) -> JSONResponse:
    """A database error: 507 when storage is full, 503 when the database is unavailable
    for a moment (``app.db.errors``); anything else stays unexpected (raised on, to
    ``_on_unexpected``)."""
    if storage_full(exc):
        return _storage_full_response(exc)
    if not database_unavailable(exc):
        raise exc
    return _condition_response(database_unavailable_problem(), exc, logging.WARNING)


async def _on_file_error(_request: Request, exc: Exception) -> JSONResponse:
    """A file error: 507 when storage is full; anything else stays unexpected."""
    if not storage_full(exc):
        raise exc
    return _storage_full_response(exc)


def database_unavailable_problem() -> Problem:
    """The 503 of a request that could not reach the database just now."""
    return Problem(
        "database-unavailable",
        "The database could not be reached just now (a restart or a fail-over); try again "
        "shortly.",
        headers={"Retry-After": str(DATABASE_RETRY_AFTER)},
    )


def storage_full_problem() -> Problem:
    """The 507 of a write that found the storage full."""
    return Problem(
        "storage-full",
        "The service's storage is full, so nothing was stored; an operator has to free "
        "space. Try again later.",
        headers={"Retry-After": str(STORAGE_FULL_RETRY_AFTER)},
    )


def _storage_full_response(exc: BaseException) -> JSONResponse:
    return _condition_response(storage_full_problem(), exc, logging.ERROR)  # needs an operator


def _condition_response(refusal: Problem, exc: BaseException, level: int) -> JSONResponse:
    """``refusal``'s response, logged in one line, not a traceback per request: the
    machine's condition, not the code, is at fault."""
    log.log(level, "%s, request refused: %s", refusal.record["title"], first_line(exc))
    return problem_response(refusal.record, headers=refusal.headers)


async def _on_unexpected(_request: Request, exc: Exception) -> JSONResponse:
    log.exception("unhandled error", exc_info=exc)
    return problem_response(
        problem("internal-error", "An unexpected error occurred; it has been logged.")
    )


def install_problem_handlers(app: FastAPI) -> None:
    app.add_exception_handler(StarletteHTTPException, _on_problem)
    app.add_exception_handler(RequestValidationError, _on_validation)
    app.add_exception_handler(InvalidShapeError, _on_invalid_shape)
    app.add_exception_handler(SolverError, _on_solver_error)
    app.add_exception_handler(DBAPIError, _on_database_error)
    app.add_exception_handler(OSError, _on_file_error)
    app.add_exception_handler(Exception, _on_unexpected)
