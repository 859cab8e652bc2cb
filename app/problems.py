"""The error catalogue: every kind of problem the service reports, in one table.

A kind is a slug; its RFC 9457 ``type`` is ``urn:shapesearch:problem:<slug>``, and its HTTP
status and ``title`` (which, as RFC 9457 asks, describes the type, not the occurrence) come
from ``CATALOGUE``. The API answers with ``problem(kind, detail)`` as ``application/problem+
json`` (``app.api.problems``), and a failed job stores the very same record, so a client
reads one shape whichever way an error reached it. Errors that only an HTTP status
describes (an unknown route: 404, a wrong method: 405) use ``about:blank`` with the status's
phrase as title; a body that cannot be parsed at all (a multipart form without its boundary,
cut short) is ``malformed-body``.
"""

from __future__ import annotations

from dataclasses import dataclass
from http import HTTPStatus
from typing import Any

__all__ = ["CATALOGUE", "Kind", "blank_problem", "problem", "reason_kind", "type_uri"]

_PREFIX = "urn:shapesearch:problem:"


@dataclass(frozen=True)
class Kind:
    """One kind of problem: its HTTP status and the title of its type."""

    status: int
    title: str


CATALOGUE: dict[str, Kind] = {
    # Input refused at the door.
    "malformed-body": Kind(400, "Malformed request body"),
    "validation-error": Kind(422, "Invalid request"),
    "too-large": Kind(413, "Too large"),
    "invalid-cursor": Kind(422, "Invalid cursor"),
    "idempotency-key-reused": Kind(422, "Idempotency key reused"),
    "webhook-url-refused": Kind(422, "Webhook URL refused"),
    "invalid-webhook-secret": Kind(422, "Invalid webhook secret"),
    # Shape files that can never be described (``core.errors.InvalidShapeError`` reasons).
    "empty-file": Kind(422, "Empty file"),
    "unknown-format": Kind(415, "Unknown file format"),
    "cad-unavailable": Kind(415, "CAD reader unavailable"),
    "unparsable": Kind(422, "Unparsable file"),
    "non-finite": Kind(422, "Non-finite coordinates"),
    "too-few-points": Kind(422, "Too few points"),
    "degenerate": Kind(422, "Degenerate shape"),
    "assembly-too-large": Kind(422, "Assembly too large"),
    # Who may ask.
    "unauthorized": Kind(401, "Unauthorized"),
    "forbidden": Kind(403, "Forbidden"),
    # What is asked about.
    "model-not-found": Kind(404, "Model not found"),
    "job-not-found": Kind(404, "Job not found"),
    "duplicates-report-not-found": Kind(404, "Duplicates report not found"),
    "webhook-not-found": Kind(404, "Webhook not found"),
    "delivery-not-found": Kind(404, "Webhook delivery not found"),
    "preview-not-available": Kind(404, "Preview not available"),
    "model-not-ready": Kind(409, "Model not ready"),
    "points-not-available": Kind(409, "Points not available"),
    "duplicate-external-id": Kind(409, "Duplicate external id"),
    "conflict": Kind(409, "Concurrent change"),
    "superseded": Kind(409, "Superseded"),
    # The service, now.
    "busy": Kind(503, "Busy"),
    "storage-full": Kind(507, "Insufficient storage"),
    "database-unavailable": Kind(503, "Database unavailable"),
    "not-ready": Kind(503, "Not ready"),
    "solver-error": Kind(503, "Solver error"),
    "worker-died": Kind(500, "Worker died"),
    "internal-error": Kind(500, "Internal error"),
}


def type_uri(kind: str) -> str:
    """The ``type`` of ``kind`` (a key of ``CATALOGUE``)."""
    if kind not in CATALOGUE:
        raise KeyError(f"no problem kind {kind!r} in the catalogue")
    return _PREFIX + kind


def problem(kind: str, detail: str, **extensions: Any) -> dict[str, Any]:
    """The problem record of ``kind``: ``type``, ``title``, ``status``, ``detail`` and any
    extension members (e.g. ``pointer``)."""
    entry = CATALOGUE[kind]
    return {
        "type": type_uri(kind), "title": entry.title, "status": entry.status,
        "detail": detail, **extensions,
    }


def blank_problem(status: int, detail: str, **extensions: Any) -> dict[str, Any]:
    """A problem that its HTTP status alone describes (``about:blank``)."""
    return {
        "type": "about:blank", "title": HTTPStatus(status).phrase, "status": status,
        "detail": detail, **extensions,
    }


def reason_kind(reason: str) -> str:
    """The kind of an ``InvalidShapeError`` reason code (``too_few_points`` ->
    ``too-few-points``)."""
    return reason.replace("_", "-")
