"""Following the database's change feed (``index_events``, see ``app.db.feed``).

An index keeps the last revision it applied and reads only newer events, a batch at a time,
so a sync that finds nothing new is two indexed reads (the events, then how far the feed was
pruned). For each model the last event of a batch wins: a model now ready is read and added
(replacing what the index held of it), any other is removed, views and all.
"""

from __future__ import annotations

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
    rebuild then)."""
    applied = 0
    with held.lock:
        while True:
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
                    return applied, True
                if not events:
                    return applied, False
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
            # Models deleted meanwhile are simply not found; their views go with them.
            held.apply(latest, [added(*row) for row in ready if row[3] and row[2]])
            held.revision = int(events[-1].revision)
            applied += len(events)
