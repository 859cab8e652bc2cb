"""Stored duplicates reports: queued as a job, stored once computed, paged, judged stale.

    enqueue_report   POST /v1/duplicates: a ``duplicates`` job (or the equal one already
                     queued or running)
    store_report     the job's (or ``shapesearch duplicates``') result: one report row and
                     one row per group; older reports of the same parameters are pruned
    latest_report    the newest report of a tenant with given parameters
    group_page       a page of a report's groups after a group number (keyset: the stored
                     numbering never changes, so pages stay put whatever happens meanwhile)
    is_stale         has the tenant's searchable set changed since the report?

Stale means an event of the tenant's change feed (``index_events``: a model became ready,
was re-described or deleted) is newer than the revision the report was computed at; one
index seek. It says the report may differ from a new one, not that it does.

Each parameter set keeps its newest ``KEPT_PER_QUERY`` reports, so a client paging one
report when a new one is stored can finish; a cursor of a pruned report is answered with
``duplicates-report-not-found``.
"""

from __future__ import annotations

import uuid
from collections.abc import Iterable
from typing import Any

from sqlalchemy import ColumnElement, Row, delete, func, insert, select, update
from sqlalchemy.orm import Session

from app.db.models import DuplicateGroup, DuplicateReport, IndexEvent, Job, Model
from app.jobs.queue import DUPLICATES
from app.jobs.turns import queue_job
from app.search.duplicates import ComputedReport, DuplicatesQuery

__all__ = [
    "KEPT_PER_QUERY",
    "enqueue_report",
    "group_page",
    "is_stale",
    "latest_report",
    "member_names",
    "query_of",
    "report_of",
    "store_report",
]

KEPT_PER_QUERY = 2
_BATCH = 1000  # group rows per INSERT, ids per IN list


def _same_query(tenant: str, query: DuplicatesQuery) -> ColumnElement[bool]:
    tolerance = (
        DuplicateReport.size_tolerance.is_(None)
        if query.size_tolerance is None
        else DuplicateReport.size_tolerance == query.size_tolerance
    )
    return (
        (DuplicateReport.tenant == tenant)
        & (DuplicateReport.descriptor_version == query.descriptor_version)
        & (DuplicateReport.min_score == query.min_score)
        & (DuplicateReport.neighbours == query.neighbours)
        & tolerance
    )


def query_of(report: DuplicateReport) -> DuplicatesQuery:
    return DuplicatesQuery(
        descriptor_version=report.descriptor_version,
        min_score=report.min_score,
        size_tolerance=report.size_tolerance,
        neighbours=report.neighbours,
    )


def enqueue_report(session: Session, tenant: str, query: DuplicatesQuery) -> Job:
    """A job computing ``query``'s report: the tenant's equal one still queued or running,
    else a new one."""
    params = query.params()
    # Starts with a write (a no-op UPDATE of the waiting jobs): on SQLite a transaction that
    # read first could not take the write lock for the INSERT (see app.db.session).
    waiting = session.execute(
        update(Job)
        .where(Job.tenant == tenant, Job.kind == DUPLICATES, Job.status.in_(("queued", "running")))
        .values(updated_at=Job.updated_at)
        .returning(Job.id, Job.params)
    ).all()
    for job_id, job_params in waiting:
        if job_params == params:
            job = session.get(Job, job_id)
            if job is not None:
                return job
    return queue_job(session, tenant=tenant, model_id=None, kind=DUPLICATES, params=params)


def store_report(
    session: Session, tenant: str, report: ComputedReport, job_id: uuid.UUID | None
) -> uuid.UUID:
    """Store ``report`` (in the caller's transaction); its id."""
    query = report.query
    row = DuplicateReport(
        tenant=tenant,
        job_id=job_id,
        descriptor_version=query.descriptor_version,
        min_score=query.min_score,
        size_tolerance=query.size_tolerance,
        neighbours=query.neighbours,
        revision=report.revision,
        models=report.models,
        group_count=len(report.groups),
        exact=report.exact,
        seconds=report.seconds,
    )
    session.add(row)
    session.flush()
    rows = [
        {
            "report_id": row.id,
            "number": number,
            "members": [str(member) for member in group.members],
            "pairs": [[i, j, round(score, 6)] for i, j, score in group.pairs],
        }
        for number, group in enumerate(report.groups, start=1)
    ]
    for start in range(0, len(rows), _BATCH):
        session.execute(insert(DuplicateGroup), rows[start : start + _BATCH])
    _prune(session, tenant, query)
    return row.id


def _prune(session: Session, tenant: str, query: DuplicatesQuery) -> None:
    """Keep the newest ``KEPT_PER_QUERY`` reports of ``query`` (their groups go with the
    others: ON DELETE CASCADE)."""
    older = session.scalars(
        select(DuplicateReport.id)
        .where(_same_query(tenant, query))
        .order_by(DuplicateReport.computed_at.desc(), DuplicateReport.id.desc())
        .offset(KEPT_PER_QUERY)
    ).all()
    if older:
        session.execute(delete(DuplicateReport).where(DuplicateReport.id.in_(older)))


def latest_report(session: Session, tenant: str, query: DuplicatesQuery) -> DuplicateReport | None:
    return session.scalar(
        select(DuplicateReport)
        .where(_same_query(tenant, query))
        .order_by(DuplicateReport.computed_at.desc(), DuplicateReport.id.desc())
        .limit(1)
    )


def report_of(session: Session, tenant: str, report_id: uuid.UUID) -> DuplicateReport | None:
    return session.scalar(
        select(DuplicateReport).where(
            DuplicateReport.id == report_id, DuplicateReport.tenant == tenant
        )
    )


def group_page(session: Session, report_id: uuid.UUID, after: int, limit: int) -> list[Row[Any]]:
    """Up to ``limit`` groups numbered after ``after``, in order: rows of ``number``,
    ``members`` and ``pairs`` (plain rows: a page holds dozens, ORM objects cost more)."""
    return list(
        session.execute(
            select(DuplicateGroup.number, DuplicateGroup.members, DuplicateGroup.pairs)
            .where(DuplicateGroup.report_id == report_id, DuplicateGroup.number > after)
            .order_by(DuplicateGroup.number)
            .limit(limit)
        )
    )


def is_stale(session: Session, report: DuplicateReport) -> bool:
    """Whether the tenant's change feed has an event newer than the report."""
    newest = session.scalar(
        select(func.max(IndexEvent.revision)).where(IndexEvent.tenant == report.tenant)
    )
    return newest is not None and newest > report.revision


def member_names(
    session: Session, tenant: str, model_ids: Iterable[str]
) -> dict[str, tuple[str | None, str | None]]:
    """``{model id: (external_id, name)}`` of the models that still exist, as they are now."""
    wanted = [uuid.UUID(model_id) for model_id in dict.fromkeys(model_ids)]
    names: dict[str, Any] = {}
    for start in range(0, len(wanted), _BATCH):
        # By id alone, the tenant checked here: given both, SQLite plans on the tenant's
        # index and reads every model of the tenant (23 ms for a page at 10^5 models).
        for model_id, owner, external_id, name in session.execute(
            select(Model.id, Model.tenant, Model.external_id, Model.name).where(
                Model.id.in_(wanted[start : start + _BATCH])
            )
        ):
            if owner == tenant:
                names[str(model_id)] = (external_id, name)
    return names
