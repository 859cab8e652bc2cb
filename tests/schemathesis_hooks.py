"""Schemathesis hooks of tests/test_schema_conformance.py: the refusals of schema-valid data
that tests/schemathesis.toml lets an operation answer (422, for what JSON Schema cannot
say) must be those refusals and no other.

The OpenAPI document states every constraint JSON Schema can express (patterns, lengths,
formats, enums, bounds); what it cannot is documented on the operation:

* whether an upload's bytes are a readable shape (a shape-file problem type);
* whether a webhook's host resolves, and to a public address (webhook-url-refused);
* a metadata object's nested keys and strings, depth and size: a schema that says so
  recurses, which client generators cannot read (validation-error pointing into
  ``/metadata``; its top-level keys are in the schema).

For those operations the toml adds 422 to the statuses positive data may get, and
``only_unstated_limits_refuse`` narrows it back to exactly these refusals, so a refused
field that the schema does describe (a name, units, a cursor) still fails the run.
"""

from __future__ import annotations

from typing import Any

import schemathesis

_PREFIX = "urn:shapesearch:problem:"
# A shape file that can never be described (app.problems: InvalidShapeError reasons).
_SHAPE_FILE = tuple(
    _PREFIX + kind
    for kind in ("empty-file", "unparsable", "non-finite", "too-few-points", "degenerate")
)
_WEBHOOK_URL = (_PREFIX + "webhook-url-refused",)


def _nested_metadata(body: dict[str, Any]) -> bool:
    """A metadata refusal below the top-level keys, or of the whole object's size."""
    pointer = body.get("pointer", "")
    return body.get("type") == _PREFIX + "validation-error" and (
        pointer.startswith("/metadata/")
        or (pointer == "/metadata" and "bytes of JSON" in body.get("detail", ""))
    )


def _shape_or_metadata(body: dict[str, Any]) -> bool:
    return body.get("type") in _SHAPE_FILE or _nested_metadata(body)


#: "METHOD path" -> whether a 422 body is one of the refusals the schema cannot state.
UNSTATED_LIMITS = {
    "POST /v1/models": _shape_or_metadata,
    "PUT /v1/models/by-external-id/{external_id}": _shape_or_metadata,
    "POST /v1/search": lambda body: body.get("type") in _SHAPE_FILE,
    "PATCH /v1/models/{model_id}": _nested_metadata,
    "POST /v1/webhooks": lambda body: body.get("type") in _WEBHOOK_URL,
}


@schemathesis.check
def only_unstated_limits_refuse(ctx: Any, response: Any, case: Any) -> bool | None:
    """A 422 to schema-valid data is one of the operation's refusals that the schema
    cannot state (module docstring)."""
    if response.status_code != 422 or case.meta is None:
        return None
    if not case.meta.generation.mode.is_positive:
        return None
    operation = f"{case.method.upper()} {case.operation.path}"
    body = response.json()
    allowed = UNSTATED_LIMITS.get(operation)
    if allowed is None or not allowed(body):
        raise AssertionError(
            f"{operation} refused schema-valid data with {body.get('type')} at "
            f"{body.get('pointer')!r}: {body.get('detail')}"
        )
    return None
