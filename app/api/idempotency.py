"""``Idempotency-Key`` on POST /v1/models: a retried request gets the first answer back.

The first request stores its answer under (tenant, key) in the transaction that creates the
model, with a digest of what was asked (file sha256, external id, name, metadata). A retry
with the same digest gets that answer (same model id, no second model); another request
with the same key gets 422. Keys are kept; they are small.
"""

from __future__ import annotations

import hashlib
import json
from datetime import datetime, timedelta
from typing import Any

from fastapi.responses import JSONResponse
from pydantic import BaseModel
from sqlalchemy import delete, select
from sqlalchemy.orm import Session, sessionmaker

from app.api.problems import Problem
from app.db.models import IdempotencyKey, utcnow

__all__ = ["remember", "replay_or_refuse", "request_sha256"]


def request_sha256(
    file_sha256: str,
    external_id: str | None,
    name: str | None,
    meta: dict[str, Any],
    units: str | None = None,
    background: bool = False,
) -> str:
    """The digest that says whether two requests ask for the same thing (``units`` counts
    only when given and ``background`` only when true, so that digests stored before they
    existed still match)."""
    fields: list[Any] = [file_sha256, external_id, name, meta]
    if units is not None:
        fields.append(units)
    if background:
        fields.append({"background": True})
    canonical = json.dumps(fields, sort_keys=True)
    return hashlib.sha256(canonical.encode()).hexdigest()


def replay_or_refuse(
    sessions: sessionmaker[Session], tenant: str, key: str, digest: str, ttl_seconds: float
) -> JSONResponse | None:
    """The stored answer for ``key`` (None if the key is new, or older than
    ``ttl_seconds``: an expired key is forgotten); 422 if it was used for another request."""
    with sessions.begin() as session:
        session.execute(
            delete(IdempotencyKey).where(
                IdempotencyKey.tenant == tenant, IdempotencyKey.key == key,
                IdempotencyKey.created_at < _cutoff(ttl_seconds),
            )
        )
    with sessions() as session:
        stored = session.scalar(
            select(IdempotencyKey).where(
                IdempotencyKey.tenant == tenant, IdempotencyKey.key == key
            )
        )
    if stored is None:
        return None
    if stored.request_sha256 != digest:
        raise Problem(
            "idempotency-key-reused",
            "This Idempotency-Key was already used with a different request; "
            "use a new key for a new request.",
        )
    headers = {"Idempotent-Replayed": "true"}
    model_id = stored.response.get("id")
    if model_id:
        headers["Location"] = f"/v1/models/{model_id}"
    return JSONResponse(stored.response, status_code=stored.status_code, headers=headers)


def remember(
    session: Session, tenant: str, key: str, digest: str, status: int, answer: BaseModel,
    ttl_seconds: float,
) -> None:
    """Store ``answer`` under ``key`` in the caller's transaction, and forget the tenant's
    keys older than ``ttl_seconds`` (so that the table does not grow without bound)."""
    session.execute(
        delete(IdempotencyKey).where(
            IdempotencyKey.tenant == tenant,
            IdempotencyKey.created_at < _cutoff(ttl_seconds),
        )
    )
    session.add(
        IdempotencyKey(
            tenant=tenant,
            key=key,
            request_sha256=digest,
            status_code=status,
            response=answer.model_dump(mode="json"),
        )
    )


def _cutoff(ttl_seconds: float) -> datetime:
    return utcnow() - timedelta(seconds=ttl_seconds)

