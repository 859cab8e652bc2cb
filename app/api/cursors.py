"""Keyset cursors of the listings: the newest-first ones (``GET /v1/models``,
``GET /v1/jobs``) and the pages of a stored duplicates report (``GET /v1/duplicates``).

A cursor is the key of the last row of a page, as url-safe base64 of a JSON pair: the
(created_at, id) of a model or job, or the (report id, group number) of a report's group.
Opaque to clients, stable while rows are added, and checked when read back.
"""

from __future__ import annotations

import base64
import binascii
import json
import uuid
from datetime import datetime
from typing import Protocol

from app.api.problems import Problem

__all__ = ["decode_cursor", "decode_group_cursor", "encode_cursor", "encode_group_cursor"]


class _Keyed(Protocol):
    created_at: datetime
    id: uuid.UUID


def encode_cursor(row: _Keyed) -> str:
    """The cursor that continues after ``row``."""
    return _encode([row.created_at.isoformat(), str(row.id)])


def decode_cursor(cursor: str) -> tuple[datetime, uuid.UUID]:
    """(created_at, id) of a cursor; 422 ``invalid-cursor`` if it is not one of ours."""
    created_at, row_id = _decode(cursor)
    try:
        return datetime.fromisoformat(created_at), uuid.UUID(row_id)
    except (ValueError, TypeError, AttributeError) as error:
        raise _invalid() from error


def encode_group_cursor(report_id: uuid.UUID, number: int) -> str:
    """The cursor that continues report ``report_id`` after its group ``number``."""
    return _encode([str(report_id), number])


def decode_group_cursor(cursor: str) -> tuple[uuid.UUID, int]:
    """(report id, group number) of a cursor; 422 ``invalid-cursor`` if it is not one."""
    report_id, number = _decode(cursor)
    if type(number) is not int or number < 0:
        raise _invalid()
    try:
        return uuid.UUID(report_id), number
    except (ValueError, TypeError, AttributeError) as error:
        raise _invalid() from error


def _encode(pair: list[object]) -> str:
    raw = json.dumps(pair).encode()
    return base64.urlsafe_b64encode(raw).decode().rstrip("=")


def _decode(cursor: str) -> list[object]:
    """The JSON pair in a cursor."""
    try:
        pair = json.loads(base64.urlsafe_b64decode(cursor + "=" * (-len(cursor) % 4)))
    except (ValueError, TypeError, binascii.Error) as error:
        raise _invalid() from error
    if not isinstance(pair, list) or len(pair) != 2:
        raise _invalid()
    return pair


def _invalid() -> Problem:
    return Problem("invalid-cursor", "cursor is not valid; pass next_cursor unchanged.")
