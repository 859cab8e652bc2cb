"""The change feed: models entering and leaving the searchable set, in commit order.

Every event takes its revision from the single ``feed_state`` row inside the writer's
transaction. The row lock (PostgreSQL) or the database lock (SQLite) is held until commit,
so revision r+1 can only commit after r: a reader that has seen r+1 has seen everything
before it and can keep one number, the last revision applied. Each event names the model's
tenant too: a tenant's newest revision tells whether its stored duplicates reports are stale
(``app.search.duplicate_reports``). The commit rings the feed's doorbell
(``app.db.doorbells``): each API process's index syncs at once, not at its next poll.
"""

from __future__ import annotations

import numpy as np
from sqlalchemy import insert, select, update
from sqlalchemy.orm import Session

from app.db.doorbells import FEED, announce
from app.db.models import FeedState, IndexEvent

__all__ = ["event_stamp", "models_touched", "record_event"]


def record_event(session: Session, index_id: int, kind: str, tenant: str) -> int:
    """Append ``kind`` ("ready" or "deleted") for model ``index_id`` of ``tenant``; returns
    its revision."""
    revision = session.execute(
        update(FeedState)
        .where(FeedState.id == 1)
        .values(revision=FeedState.revision + 1)
        .returning(FeedState.revision)
    ).scalar_one()
    session.execute(insert(IndexEvent).values(
        revision=revision, index_id=index_id, kind=kind, tenant=tenant
    ))
    announce(session, FEED)
    return int(revision)


def event_stamp(session: Session, revision: int) -> str | None:
    """The event at ``revision`` as text (model, kind, time; empty at revision 0), or None
    when the feed holds none there (pruned). Two databases whose feeds went different ways
    after a common past have different ones."""
    if revision == 0:
        return ""
    event = session.execute(
        select(IndexEvent.index_id, IndexEvent.kind, IndexEvent.created_at)
        .where(IndexEvent.revision == revision)
    ).one_or_none()
    return None if event is None else " ".join(str(value) for value in event)


def models_touched(session: Session, after: int, through: int) -> np.ndarray | None:
    """``(t,) int64``: the models that events after revision ``after`` up to ``through``
    name; None when some of them were pruned (``app.db.retention``), or ``after`` is ahead
    of ``through``."""
    if after > through:
        return None
    touched = session.scalars(
        select(IndexEvent.index_id)
        .where(IndexEvent.revision > after, IndexEvent.revision <= through)
        .distinct()
    ).all()
    # Read after the events: a pruning that deleted one of them before that read had
    # committed, and so shows here.
    pruned_through = session.execute(
        select(FeedState.pruned_through).where(FeedState.id == 1)
    ).scalar_one()
    return None if pruned_through > after else np.asarray(touched, dtype=np.int64)
