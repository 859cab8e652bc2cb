"""Following the database's change feed (``index_events``, see ``app.db.feed``).

An index keeps the last revision it applied and reads only newer events, a batch at a time,
so a sync that finds nothing new is two indexed reads (the events, then how far the feed was
pruned). For each model the last event of a batch wins: a model now ready is read and added
(replacing what the index held of it), any other is removed, views and all.

With the Milvus backend (``_milvus``) each batch is read and applied holding the Milvus
writer's lock, and written to Milvus only when Milvus is not in step with it already
(another process wrote it: ``MilvusStore.revision``); the revision is recorded in Milvus
after the batch's vectors, so a batch cut short (a process killed between the database and
Milvus) is replayed whole by the next sync, of this process or another.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import cast

from sqlalchemy import select

from app.db.models import FeedState, IndexEvent, Model
from app.search.index._held import Held
from app.search.index._rows import ModelRows, Row, added

__all__ = ["follow"]

_EVENT_BATCH = 5000


def follow(held: Held, rows: ModelRows) -> tuple[int, bool]:
    """Apply the events newer than ``held.revision`` to ``held``: how many, and whether some
    of them were pruned before they could be read (``app.db.retention``: the index must
    rebuild then; with Milvus, also when Milvus was never built or was wiped)."""
    applied = 0
    with held.lock:
        while True:
            with _writer(held, rows) as remote:
                if held.store is not None:
                    if remote is None:
                        return applied, True
                    # Milvus behind this process (a wiped or restored server): replay.
                    held.revision = min(held.revision, remote)
                count, missed = _batch(held, rows, remote)
            if missed or count == 0:
                return applied, missed
            applied += count


@contextlib.contextmanager
def _writer(held: Held, rows: ModelRows) -> Iterator[int | None]:
    """With Milvus, its writer's lock held and the revision it is in step with; else
    nothing."""
    if held.store is None:
        yield None
        return
    with held.store.writer(rows.sessions):
        yield held.store.revision()


def _batch(held: Held, rows: ModelRows, remote: int | None) -> tuple[int, bool]:
    """Apply one batch of events: how many, and whether the feed was pruned past them."""
    with rows.sessions() as session:
        events = session.execute(
            select(IndexEvent.revision, IndexEvent.index_id, IndexEvent.kind)
            .where(IndexEvent.revision > held.revision)
            .order_by(IndexEvent.revision)
            .limit(_EVENT_BATCH)
        ).all()
        # Read after the events: a pruning that deleted one of them before
        # that read had committed, and so shows here.
        pruned_through = session.execute(
            select(FeedState.pruned_through).where(FeedState.id == 1)
        ).scalar_one()
        if pruned_through > held.revision:
            return 0, True
        if not events:
            return 0, False
        latest = {event.index_id: event.kind for event in events}  # last one wins
        wanted = [i for i, kind in latest.items() if kind == "ready"]
        ready = cast(list[Row], (
            session.execute(
                select(*rows.columns()).where(
                    Model.index_id.in_(wanted),
                    Model.status == "ready",
                    rows.in_scope(),
                )
            ).all()
            if wanted
            else []
        ))
    last = int(events[-1].revision)
    store = held.store
    writing = store is not None and remote is not None and last > remote
    if store is not None:
        store.writing = writing
        if writing:  # Milvus may lag what this process was built from: gone first
            store.forget(list(latest))
    try:
        # Models deleted meanwhile are simply not found; their views go with them.
        held.apply(latest, [added(*row) for row in ready if row[3] and row[2]])
    finally:
        if store is not None:
            store.writing = True
    held.revision = last
    if store is not None and writing:
        store.set_revision(last)  # after the vectors: a kill before it replays the batch
    return len(events), False
