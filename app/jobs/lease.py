"""Leased claims on a table of work rows, shared by the job queue and webhook delivery.

A row is *waiting* (due once ``run_after`` has passed) or *held* by one worker until
``leased_until``; a held row whose lease expired is due again (its worker died). Claiming is
one statement:

    UPDATE t SET status=:held, worker_id=:w, attempts=attempts+1, leased_until=:now+lease
    WHERE id = (SELECT id FROM t
                WHERE (status=:waiting AND run_after <= :now)
                   OR (status=:held AND leased_until < :now)
                ORDER BY turn, run_after LIMIT 1
                FOR UPDATE SKIP LOCKED)                              -- PostgreSQL only
    RETURNING ...

Due rows go in turn order, then oldest first: jobs take turns among tenants and webhook
deliveries among endpoints (``app.jobs.turns``).

On PostgreSQL ``SKIP LOCKED`` lets concurrent workers pass over each other's candidate rows;
SQLite has a single writer, so the statement is atomic as it stands. A failed attempt waits
``backoff_seconds`` before the row is due again. A caller may narrow the candidates to rows
it chose (``among``): the deliverers take only the next delivery of each endpoint with none
in flight (``app.webhooks.delivery``).
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime, timedelta
from typing import Any

from sqlalchemy import Row, and_, or_, select, true, update
from sqlalchemy.orm import Session

__all__ = ["backoff_seconds", "claim_next"]


def backoff_seconds(attempts: int, base: float, cap: float) -> float:
    """Delay after failed attempt number ``attempts``: base, 2*base, 4*base, ... <= cap."""
    return min(cap, base * 2 ** max(0, attempts - 1))


def claim_next(
    session: Session,
    table: Any,
    *,
    waiting: str,
    held: str,
    worker_id: str,
    now: datetime,
    lease: timedelta,
    returning: tuple[Any, ...],
    among: Sequence[Any] | None = None,
) -> Row[Any] | None:
    """Claim the next due row of ``table`` (an ORM class with ``id``, ``status``,
    ``turn``, ``run_after``, ``worker_id``, ``attempts``, ``leased_until`` and
    ``updated_at``) for ``worker_id``, the first by turn then by ``run_after``; returns the
    ``returning`` columns of the claimed row, or None.

    ``among``: the ids of the only rows to consider (a short list: the claim then looks
    them up by primary key).
    """
    first = (
        select(table.id)
        .where(
            or_(
                and_(table.status == waiting, table.run_after <= now),
                and_(table.status == held, table.leased_until < now),
            ),
            true() if among is None else table.id.in_(among),
        )
        .order_by(table.turn, table.run_after)
        .limit(1)
        .with_for_update(skip_locked=True)  # rendered on PostgreSQL, ignored by SQLite
        .scalar_subquery()
    )
    return session.execute(
        update(table)
        .where(table.id == first)
        .values(
            status=held,
            worker_id=worker_id,
            attempts=table.attempts + 1,
            leased_until=now + lease,
            updated_at=now,
        )
        .returning(*returning)
    ).one_or_none()
