"""Limits on what clients send besides the file: text fields, query parameters, metadata.

Every value a client sends is checked before it reaches the database, so that bad input is
a 422 that points at the field instead of a 500 from a driver (PostgreSQL refuses NUL in
text and NaN in JSON) or a RecursionError deep inside a serializer:

* text (external_id, name, filename, query parameters): at most ``max_text_length``
  characters, no NUL, valid UTF-8 (no lone surrogates, which JSON ``\\ud800`` can smuggle in);
* metadata: a JSON object nested at most ``max_metadata_depth`` levels, at most
  ``max_metadata_bytes`` as compact JSON, finite numbers only, keys and strings valid text.

``InputLimits`` holds the limits (built from the settings); ``QueryGuard`` applies the text
rules to every query parameter of every route and refuses one given twice; ``fields_once``,
a dependency of the upload routes, refuses a form field given twice (two files: one would
be dropped unseen). Each violation raises ``Problem(422, slug="validation-error",
pointer=...)`` with a JSON pointer to the field.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any
from urllib.parse import parse_qsl

from fastapi import Request
from starlette.types import ASGIApp, Receive, Scope, Send

from app.api.problems import Problem, problem_response
from app.settings import Settings

__all__ = [
    "JSON_OBJECT_FIELD",
    "METADATA_HELP",
    "METADATA_SCHEMA",
    "InputLimits",
    "QueryGuard",
    "fields_once",
    "invalid_input",
]

# Compact JSON may be this many times shorter than what the client sent (indentation);
# beyond it the text is refused before it is parsed at all.
_WHITESPACE_ALLOWANCE = 4

#: What JSON Schema states of a metadata object: its keys hold no NUL. Its nested keys and
#: strings, its depth and its size are checked too (``InputLimits.metadata``), but a
#: schema that says so recurses, which client generators cannot read: METADATA_HELP
#: says it in words.
METADATA_SCHEMA: dict[str, Any] = {"type": "object", "propertyNames": {"pattern": r"^[^\x00]*$"}}
#: ``json_schema_extra`` of a form field that holds a JSON object (``metadata``): the
#: OpenAPI document declares it as an application/json part (``app.api.openapi``).
JSON_OBJECT_FIELD: dict[str, Any] = {
    "contentMediaType": "application/json", "contentSchema": METADATA_SCHEMA,
}
METADATA_HELP = (
    "A JSON object, nested at most SHAPESEARCH_MAX_METADATA_DEPTH levels (default 8), at "
    "most SHAPESEARCH_MAX_METADATA_BYTES (default 16384) as compact JSON, its keys and "
    "strings without NUL at every level (else 422 validation-error pointing into it)."
)


def invalid_input(pointer: str, detail: str) -> Problem:
    """The 422 for one invalid field; ``pointer`` is a JSON pointer such as ``/metadata/a``."""
    return Problem(
        "validation-error",
        f"{pointer or 'the request'}: {detail}",
        pointer=pointer,
        errors=[{"pointer": pointer, "detail": detail}],
    )


async def fields_once(request: Request) -> None:
    """Each form field the route reads at most once (a route dependency): the framework
    would take the last of two files, or of two metadata objects, and drop the other
    unseen. Fields the route does not read are ignored, as the framework ignores them."""
    declared = [param.alias for param in request.scope["route"].dependant.body_params]
    form = await request.form()  # parsed once per request: the route's own parse is cached
    for name in declared:
        count = len(form.getlist(name))
        if count > 1:
            raise invalid_input(f"/{_escape(name)}", f"given {count} times; send it once")


def _escape(key: str) -> str:
    """A JSON pointer reference token (RFC 6901)."""
    return key.replace("~", "~0").replace("/", "~1")


def _text_problem(value: str) -> str | None:
    if "\x00" in value:
        return "must not contain NUL characters"
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        return "is not valid UTF-8 text"
    return None


@dataclass(frozen=True)
class InputLimits:
    """The limits on client input, with the checks that apply them."""

    max_text_length: int
    max_metadata_bytes: int
    max_metadata_depth: int

    @classmethod
    def from_settings(cls, settings: Settings) -> InputLimits:
        return cls(
            max_text_length=settings.max_text_length,
            max_metadata_bytes=settings.max_metadata_bytes,
            max_metadata_depth=settings.max_metadata_depth,
        )

    def text(self, value: str | None, pointer: str) -> str | None:
        """``value`` unchanged if it is acceptable text, else 422."""
        if value is None:
            return None
        if problem := _text_problem(value):
            raise invalid_input(pointer, problem)
        if len(value) > self.max_text_length:
            raise invalid_input(
                pointer, f"is longer than the limit of {self.max_text_length} characters"
            )
        return value

    def metadata_text(self, text: str | None, pointer: str = "/metadata") -> dict[str, Any]:
        """Parse the ``metadata`` form field (a JSON object as a string); empty means {}."""
        if text is None or text == "":
            return {}
        if len(text) > self.max_metadata_bytes * _WHITESPACE_ALLOWANCE:
            raise invalid_input(pointer, self._too_big())
        try:
            value = json.loads(text, parse_constant=_refuse_constant)
        except RecursionError:
            raise invalid_input(pointer, self._too_deep()) from None
        except ValueError as error:  # JSONDecodeError and the refused constants
            raise invalid_input(pointer, f"is not valid JSON: {error}") from None
        return self.metadata(value, pointer)

    def metadata(self, value: Any, pointer: str = "/metadata") -> dict[str, Any]:
        """``value`` if it is an acceptable metadata object, else 422 pointing into it."""
        if not isinstance(value, dict):
            raise invalid_input(pointer, "must be a JSON object")
        self._walk(value, pointer)
        size = len(json.dumps(value, separators=(",", ":"), ensure_ascii=False).encode())
        if size > self.max_metadata_bytes:
            raise invalid_input(pointer, self._too_big(size))
        return value

    def _walk(self, root: dict[str, Any], pointer: str) -> None:
        """Check depth, numbers and text without recursion (the depth is what we bound)."""
        stack: list[tuple[Any, str, int]] = [(root, pointer, 1)]
        while stack:
            value, where, depth = stack.pop()
            if isinstance(value, dict | list):
                if depth > self.max_metadata_depth:
                    raise invalid_input(where, self._too_deep())
                items = value.items() if isinstance(value, dict) else enumerate(value)
                for key, item in items:
                    child = f"{where}/{_escape(str(key))}"
                    if isinstance(key, str) and (problem := _text_problem(key)):
                        raise invalid_input(child, f"key {problem}")
                    stack.append((item, child, depth + 1))
            elif isinstance(value, float) and not math.isfinite(value):
                raise invalid_input(where, "must be a finite number (NaN is not JSON)")
            elif isinstance(value, str) and (problem := _text_problem(value)):
                raise invalid_input(where, problem)

    def _too_deep(self) -> str:
        return f"is nested deeper than the limit of {self.max_metadata_depth} levels"

    def _too_big(self, size: int | None = None) -> str:
        actual = f" ({size} bytes)" if size is not None else ""
        return f"is larger{actual} than the limit of {self.max_metadata_bytes} bytes of JSON"


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number; use a finite number or a string")


class QueryGuard:
    """ASGI middleware: every query parameter of every route must be acceptable text, and
    given once (no parameter of the API is a list: the framework would keep the last of
    two values and drop the other unseen)."""

    def __init__(self, app: ASGIApp, limits: InputLimits) -> None:
        self.app = app
        self.limits = limits

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http" and scope.get("query_string"):
            query = scope["query_string"].decode("latin-1")
            seen: set[str] = set()
            for name, value in parse_qsl(query, keep_blank_values=True, errors="surrogateescape"):
                pointer = f"/query/{_escape(name)}"
                try:
                    self.limits.text(name, pointer)
                    self.limits.text(value, pointer)
                    if name in seen:
                        raise invalid_input(pointer, "given more than once; send it once")
                    seen.add(name)
                except Problem as problem:
                    response = problem_response(problem.record)
                    await response(scope, receive, send)
                    return
        await self.app(scope, receive, send)
