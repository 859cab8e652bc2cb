"""Similarity queries: nearest descriptors from the index, confirmed and filtered by the
database, scored.

Score: descriptors are unit vectors, so the L2 distance ``d`` lies in [0, 2] and
``score = 1 - d**2 / 4`` (clipped to [0, 1]) equals ``(1 + cos) / 2``: 1 for identical
descriptors, 0.5 for orthogonal ones, 0 for opposite ones.

Metadata filters are applied before the top-k cut: the index is searched for more and
more candidates (x4 each round) until ``k`` of them pass the filters or the partition is
exhausted. Every candidate is re-read from the database, which is the source of truth: a
model deleted by another process a moment ago is never returned.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session

from app.db.models import Model
from app.index import PartitionKey, ShapeIndex

__all__ = ["Match", "find_similar", "metadata_matches", "score_of"]


@dataclass(frozen=True)
class Match:
    model: Model
    distance: float
    score: float


def score_of(distance: float) -> float:
    return float(np.clip(1.0 - distance * distance / 4.0, 0.0, 1.0))


def metadata_matches(metadata: dict[str, Any], filters: dict[str, str]) -> bool:
    """Equality on every filter; non-string values compare by their JSON text (3, true)."""
    for key, wanted in filters.items():
        if key not in metadata:
            return False
        value = metadata[key]
        text = value if isinstance(value, str) else json.dumps(value)
        if text != wanted:
            return False
    return True


def find_similar(
    index: ShapeIndex,
    session: Session,
    key: PartitionKey,
    vector: np.ndarray,
    *,
    k: int,
    min_score: float | None = None,
    filters: dict[str, str] | None = None,
    exclude: int | None = None,
) -> list[Match]:
    """The ``k`` best matches in partition ``key`` (tenant, descriptor version)."""
    tenant = key[0]
    filters = filters or {}
    matches: list[Match] = []
    seen: set[int] = set()
    fetch = k + 1 if not filters else 4 * (k + 1)
    while True:
        hits = index.search(key, vector, fetch)
        fresh = [(i, d) for i, d in hits if i not in seen and i != exclude]
        seen.update(i for i, _ in hits)
        below_min = False
        if min_score is not None:
            kept = [(i, d) for i, d in fresh if score_of(d) >= min_score]
            below_min = len(kept) < len(fresh)  # sorted: nothing further can qualify
            fresh = kept
        if fresh:
            rows = session.scalars(
                select(Model).where(
                    Model.index_id.in_([i for i, _ in fresh]),
                    Model.tenant == tenant,
                    Model.status == "ready",
                )
            ).all()
            models = {model.index_id: model for model in rows}
            for index_id, distance in fresh:
                model = models.get(index_id)
                if model is not None and metadata_matches(model.meta or {}, filters):
                    matches.append(Match(model, distance, score_of(distance)))
        exhausted = len(hits) < fetch or fetch >= index.partition_size(key)
        if len(matches) >= k or below_min or exhausted:
            # Equal distances (identical files) in upload order, whatever order the index
            # happened to insert them in: every process answers alike.
            matches.sort(key=lambda match: (match.distance, match.model.index_id))
            return matches[:k]
        fetch *= 4
