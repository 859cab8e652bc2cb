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

from sqlalchemy import insert, update
from sqlalchemy.orm import Session

from app.db.doorbells import FEED, announce
from app.db.models import FeedState, IndexEvent

__all__ = ["record_event"]


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
