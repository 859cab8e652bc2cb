"""The JSON answers of the hot read routes (a similar list, a catalogue page), built from
trusted rows as plain values and encoded once.

Returned as a pydantic model, an answer is built model by model in Python and then checked
and encoded again by FastAPI: for a page of ten models that cost more than reading it. The
routes still declare their models (``response_model``: the OpenAPI document is theirs), but
hand FastAPI finished bytes: the values the models would hold, in their field order, encoded
as pydantic encodes them (``json_body``), so the bytes are the ones the models give
(``tests/api/test_answers.py`` checks them against the models).
"""

from __future__ import annotations

import functools
import re
import uuid
from collections.abc import Sequence
from datetime import UTC, datetime
from typing import Any

import numpy as np
import orjson
import pydantic_core
from fastapi import Response
from pydantic import TypeAdapter

from app.db.session import json_loads
from app.search.similarity import Candidate, Match
from core.cutoff import CutoffRecord
from core.rank.score_calibration import calibration_for, in_words

__all__ = [
    "JOB_COLUMNS", "JSON", "MODEL_COLUMNS", "STORED_JSON", "STORED_ROWS", "STORED_TIMES",
    "STORED_UUIDS",
    "json_body", "json_response", "model_fields", "similar_body", "size_fields",
    "stored_fields", "stored_time", "stored_uuid",
]

JSON = "application/json"

_CUTOFF = TypeAdapter(CutoffRecord)


def json_body(content: Any) -> bytes:
    """``content`` (plain values, UUIDs and datetimes) encoded as pydantic encodes a model's
    values (a non-finite float as null): by orjson, three times faster on a page of models,
    whose output is the same (shortest round-trip floats, UTF-8, ``Z`` for UTC); what orjson
    refuses (an integer beyond 64 bits in someone's metadata, a numpy scalar) by pydantic-core
    itself."""
    try:
        return orjson.dumps(content, option=orjson.OPT_UTC_Z)
    except TypeError:  # orjson.JSONEncodeError
        return pydantic_core.to_json(content, inf_nan_mode="null")


def json_response(content: Any) -> Response:
    """``content`` as a JSON answer (``json_body``)."""
    return Response(json_body(content), media_type=JSON)


def size_fields(
    length: float | None, width: float | None, height: float | None, area: float | None,
    volume: float | None, units: str | None,
) -> dict[str, Any] | None:
    """``app.api.schemas.size_of`` as plain values."""
    if length is None or width is None or height is None or area is None:
        return None
    return {"length": length, "width": width, "height": height, "area": area,
            "volume": volume, "units": units}


def _summary(model: Candidate) -> dict[str, Any]:
    """``app.api.schemas.model_summary`` as plain values."""
    shape = model.size
    return {
        "id": model.id, "external_id": model.external_id, "name": model.name,
        "metadata": model.meta or {},
        "size": None if shape is None else size_fields(
            shape.length, shape.width, shape.height, shape.area, shape.volume, model.units),
    }


def similar_body(model_id: uuid.UUID, matches: Sequence[Match], descriptor_version: str) -> Any:
    """A ``SimilarResponse`` as plain values (``app.api.schemas.similar_results``); the
    calibration interpolates every score in one call."""
    calibration = calibration_for(descriptor_version)
    calibrated: Sequence[float | None] = [None] * len(matches)
    if calibration is not None and matches:
        calibrated = np.interp([m.score for m in matches], calibration.quantiles,
                               calibration.probabilities_).tolist()
    return {
        "query": {"model_id": model_id},
        "results": [
            {"model": _summary(m.model), "distance": m.distance, "score": m.score,
             "calibrated_score": c, "likeness": None if c is None else in_words(c)}
            for m, c in zip(matches, calibrated, strict=True)
        ],
    }


#: The columns ``model_fields`` reads (``Model`` attribute names), in its order.
MODEL_COLUMNS = (
    "id", "external_id", "name", "meta", "status", "error", "file_name", "file_size",
    "file_sha256", "file_format", "n_points", "size_length", "size_width", "size_height",
    "size_area", "size_volume", "units", "cutoff", "descriptor_version", "timings",
    "created_at", "updated_at",
)
#: The columns of a model's latest job that ``model_fields`` reads (``Job`` attributes).
JOB_COLUMNS = ("id", "status", "attempts", "created_at", "updated_at")
#: Of ``MODEL_COLUMNS`` and ``JOB_COLUMNS``, those that SQLite stores as text to decode: a
#: UUID's hex, JSON, a UTC time (``stored_fields`` reads them as stored).
STORED_UUIDS = frozenset({"id"})
STORED_JSON = frozenset({"meta", "error", "cutoff", "timings"})
STORED_TIMES = frozenset({"created_at", "updated_at"})


def model_fields(row: Sequence[Any], job: Sequence[Any] | None) -> dict[str, Any]:
    """A ``ModelResource`` as plain values (``app.api.schemas.model_resource``) from a row of
    ``MODEL_COLUMNS`` and one of ``JOB_COLUMNS`` (None: no job), as SQLAlchemy's types give
    them."""
    return _resource(row, _cutoff(row[_CUTOFF_AT]),
                     None if job is None else dict(zip(JOB_COLUMNS, job, strict=True)))


def stored_fields(row: Sequence[Any], job: Sequence[Any] | None) -> dict[str, Any]:
    """``model_fields`` of a row as SQLite stores it (the ``STORED_*`` columns as text): the
    same answer without SQLAlchemy's decoding of each value (UUID and datetime objects that
    pydantic then writes out again: a third of a page's time).

    Kept per process for the ``STORED_ROWS`` rows last read, by everything they hold (the
    text as stored, each value: a row that changed in any column is another key), so a page
    of models read again decodes only what changed; the values are shared, never changed."""
    return _stored_fields(tuple(row), None if job is None else tuple(job))


#: Decoded rows kept per process (``stored_fields``): about 2 KB each.
STORED_ROWS = 4096


@functools.lru_cache(maxsize=STORED_ROWS)
def _stored_fields(row: tuple[Any, ...], job: tuple[Any, ...] | None) -> dict[str, Any]:
    values = list(row)
    values[_ID_AT] = stored_uuid(values[_ID_AT])
    for at in _JSON_AT:
        values[at] = None if values[at] is None else json_loads(values[at])
    for at in _TIMES_AT:
        values[at] = stored_time(values[at])
    cutoff = None if row[_CUTOFF_AT] is None else _stored_cutoff(row[_CUTOFF_AT])
    latest = None
    if job is not None:
        latest = dict(zip(JOB_COLUMNS, job, strict=True))
        latest["id"] = stored_uuid(latest["id"])
        latest["created_at"] = stored_time(latest["created_at"])
        latest["updated_at"] = stored_time(latest["updated_at"])
    return _resource(values, cutoff, latest)


_ID_AT = MODEL_COLUMNS.index("id")
_CUTOFF_AT = MODEL_COLUMNS.index("cutoff")
_JSON_AT = [MODEL_COLUMNS.index(name) for name in ("meta", "error", "timings")]
_TIMES_AT = [MODEL_COLUMNS.index(name) for name in STORED_TIMES]


def _resource(row: Sequence[Any], cutoff: Any, job: dict[str, Any] | None) -> dict[str, Any]:
    (model_id, external_id, name, meta, status, error, file_name, file_size, file_sha256,
     file_format, n_points, length, width, height, area, volume, units, _,
     descriptor_version, timings, created_at, updated_at) = row
    return {
        "id": model_id, "external_id": external_id, "name": name, "metadata": meta or {},
        "status": status,
        "error": None if not error else {
            "type": error["type"], "title": error["title"], "detail": error["detail"]},
        "file": {"filename": file_name, "size": file_size, "sha256": file_sha256,
                 "format": file_format},
        "n_points": n_points,
        "size": size_fields(length, width, height, area, volume, units),
        "cutoff": cutoff,
        "descriptor_version": descriptor_version,
        "timings": timings,
        "created_at": created_at,
        "updated_at": updated_at,
        "job": job,
    }


def _cutoff(stored: dict[str, Any] | None) -> Any:
    """``app.api.schemas.cutoff_record`` as the model encodes it (its field types applied:
    an integer where a float is declared is written as a float)."""
    if not stored:
        return None
    return _CUTOFF.dump_python(_CUTOFF.validate_python(CutoffRecord.from_json(stored)),
                               mode="json")


@functools.lru_cache(maxsize=4096)
def _stored_cutoff(text: str) -> Any:
    """``_cutoff`` of a stored cutoff's JSON text (shared: never changed by a caller)."""
    return _cutoff(json_loads(text))


_HEX = re.compile(r"[0-9a-f]{32}")
# How SQLAlchemy stores a UTC time on SQLite (``app.db.models.UTCDateTime``).
_STORED_TIME = re.compile(r"([0-9]{4}-[0-9]{2}-[0-9]{2}) ([0-9]{2}:[0-9]{2}:[0-9]{2})"
                          r"(?:\.([0-9]{6}))?")


def stored_uuid(text: str) -> Any:
    """A UUID stored as its hex, as pydantic writes it (hyphenated lower-case hex)."""
    if _HEX.fullmatch(text) is None:
        return uuid.UUID(text)
    return f"{text[:8]}-{text[8:12]}-{text[12:16]}-{text[16:20]}-{text[20:]}"


def stored_time(text: str | None) -> Any:
    """A UTC time stored as SQLite text, as pydantic writes the aware datetime
    (``...T15:23:35.960899Z``, the fraction left out when it is 0)."""
    if text is None:
        return None
    if len(text) == 26 and text[10] == " " and text[19] == "." and _STORED_TIME.fullmatch(text):
        return f"{text[:10]}T{text[11:19]}Z" if text.endswith(".000000") else (
            f"{text[:10]}T{text[11:]}Z")
    found = _STORED_TIME.fullmatch(text)
    if found is None:  # not as SQLAlchemy writes it: as SQLAlchemy would read it
        return datetime.fromisoformat(text).replace(tzinfo=UTC)
    day, time, micros = found.groups()
    return f"{day}T{time}Z" if micros is None or micros == "000000" else f"{day}T{time}.{micros}Z"
