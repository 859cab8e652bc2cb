"""Keyset cursors of the newest-first listings (``GET /v1/models``, ``GET /v1/jobs``).

A cursor is the (created_at, id) of the last row of a page, as url-safe base64 of a JSON
pair: opaque to clients, stable while rows are added, and checked when read back.
"""

from __future__ import annotations

import base64
import binascii
import json
import uuid
from datetime import datetime
from typing import Protocol

from app.api.problems import Problem

__all__ = ["decode_cursor", "encode_cursor"]


class _Keyed(Protocol):
    created_at: datetime
    id: uuid.UUID


def encode_cursor(row: _Keyed) -> str:
    """The cursor that continues after ``row``."""
    raw = json.dumps([row.created_at.isoformat(), str(row.id)]).encode()
    return base64.urlsafe_b64encode(raw).decode().rstrip("=")


def decode_cursor(cursor: str) -> tuple[datetime, uuid.UUID]:
    """(created_at, id) of a cursor; 422 ``invalid-cursor`` if it is not one of ours."""
    try:
        raw = base64.urlsafe_b64decode(cursor + "=" * (-len(cursor) % 4))
        created_at, row_id = json.loads(raw)
        return datetime.fromisoformat(created_at), uuid.UUID(row_id)
    except (ValueError, TypeError, binascii.Error) as error:
        raise Problem(
            "invalid-cursor", "cursor is not valid; pass next_cursor unchanged."
        ) from error
