"""Cursors of the paged listings (``GET /v1/models``, ``/v1/jobs``, ``/v1/duplicates``): one
rule for every one of them.

* An absent or empty ``cursor`` is the first page; any other is the ``next_cursor`` of the
  previous page, passed unchanged. ``next_cursor`` is null on the last page.
* A keyset cursor (the newest-first listings) is the position after the last row of a page:
  its ``created_at`` in microseconds since the epoch and its id, ``<micros>-<32 hex>``;
  stable while rows come and go. A group cursor (the pages of a stored duplicates report) is
  the report's id and the number of the last group shown, ``<32 hex>-<number>``: it pages
  that report, whatever is computed after it.
* Each kind is declared with a pattern in the OpenAPI document, and every string that
  matches it is a position the listing can continue from (past the end: an empty page), so
  the document says exactly what is accepted: anything else is 422 ``invalid-cursor``.
"""

from __future__ import annotations

import re
import uuid
from datetime import UTC, datetime, timedelta
from typing import Annotated, Protocol

from fastapi import Query

from app.api.problems import Problem

__all__ = [
    "KeysetCursor",
    "GroupCursor",
    "encode_group",
    "encode_keyset",
    "group_after",
    "keyset_after",
]

_EPOCH = datetime(1970, 1, 1, tzinfo=UTC)
_MICROSECOND = timedelta(microseconds=1)
# 17 digits of microseconds reach the year 5138, inside what datetime can hold.
_KEYSET = r"^([0-9]{1,17}-[0-9a-f]{32})?$"
_GROUP = r"^([0-9a-f]{32}-[0-9]{1,9})?$"
_HELP = "The previous page's next_cursor, unchanged; empty or absent: the first page."

KeysetCursor = Annotated[
    str, Query(description=_HELP, json_schema_extra={"pattern": _KEYSET, "maxLength": 50})
]
GroupCursor = Annotated[
    str, Query(description=_HELP, json_schema_extra={"pattern": _GROUP, "maxLength": 42})
]


class _Keyed(Protocol):
    created_at: datetime
    id: uuid.UUID


def _checked(cursor: str, pattern: str) -> str:
    if re.fullmatch(pattern, cursor) is None:
        raise Problem("invalid-cursor", "cursor is not valid; pass next_cursor unchanged.")
    return cursor


def encode_keyset(row: _Keyed) -> str:
    """The cursor that continues after ``row`` (``created_at`` aware, as the database
    columns give it)."""
    micros = (row.created_at - _EPOCH) // _MICROSECOND
    return f"{micros}-{row.id.hex}"


def keyset_after(cursor: str) -> tuple[datetime, uuid.UUID] | None:
    """(created_at, id) that the page continues after; None for the first page; 422
    ``invalid-cursor`` if ``cursor`` does not match the keyset pattern."""
    if not _checked(cursor, _KEYSET):
        return None
    micros, _, hex_id = cursor.partition("-")
    return _EPOCH + int(micros) * _MICROSECOND, uuid.UUID(hex=hex_id)


def encode_group(report_id: uuid.UUID, number: int) -> str:
    """The cursor that continues report ``report_id`` after its group ``number``."""
    return f"{report_id.hex}-{number}"


def group_after(cursor: str) -> tuple[uuid.UUID, int] | None:
    """(report id, group number) that the page continues after; None for the first page;
    422 ``invalid-cursor`` if ``cursor`` does not match the group pattern."""
    if not _checked(cursor, _GROUP):
        return None
    hex_id, _, number = cursor.partition("-")
    return uuid.UUID(hex=hex_id), int(number)
