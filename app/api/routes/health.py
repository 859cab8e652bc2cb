"""/healthz (the process is alive) and /readyz (it can serve correct answers)."""

from __future__ import annotations

import logging
import time
from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse
from sqlalchemy import func, select, text

from app.api.deps import Services, ServicesDep
from app.api.problems import problem_response, problem_responses
from app.api.schemas import Health
from app.db.migrate import is_at_head
from app.db.models import FeedState, Model
from app.problems import problem

__all__ = ["router"]

router = APIRouter(tags=["health"])

log = logging.getLogger("shapesearch.api")


@router.get("/healthz", response_model=Health, response_model_exclude_none=True, summary="Liveness")
async def healthz() -> Health:
    # async: answered on the event loop, never queued behind describes in the threadpool
    return Health(status="ok")


def _index_check(services: Services, state: Any) -> str | None:
    """None when the index is in step with the database, else why not.

    Every probe compares the change-feed revision applied with the database's (one
    primary-key read). Counting the ready models, which also catches rows changed behind
    the feed's back, costs a scan of the table, so it runs at most once per
    ``readyz_count_seconds`` and its verdict is remembered in between.
    """
    index = services.index
    index.sync()  # cheap when nothing is new; the background sync does the same
    now = time.monotonic()
    last = getattr(state, "readyz_count", None)
    if last is None or now - last[0] >= services.settings.readyz_count_seconds:
        last = (now, _count_check(services))
        state.readyz_count = last
    if last[1] is not None:
        return last[1]
    with services.sessions() as session:
        revision = session.execute(select(FeedState.revision).where(FeedState.id == 1)).scalar_one()
    behind = int(revision) - index.revision
    if behind > 0:
        return f"index is {behind} change-feed revisions behind the database"
    return None


def _count_check(services: Services) -> str | None:
    """None when the index holds exactly the database's ready models, else why not."""
    index = services.index
    for _ in range(3):  # a model may become ready between the sync and the count
        index.sync()
        with services.sessions() as session:
            # One statement, one snapshot: the revision and the count belong together.
            revision, ready = session.execute(
                select(
                    select(FeedState.revision).where(FeedState.id == 1).scalar_subquery(),
                    select(func.count())
                    .select_from(Model)
                    .where(Model.status == "ready")
                    .scalar_subquery(),
                )
            ).one()
        if revision == index.revision:
            if ready == len(index):
                return None
            return f"index holds {len(index)} models, the database {ready} ready ones"
    return "index is behind the change feed"


@router.get(
    "/readyz",
    response_model=Health,
    responses=problem_responses(503),
    summary="Readiness: database reachable, migrations at head, index in step",
)
def readyz(request: Request, services: ServicesDep) -> Health | JSONResponse:
    checks: dict[str, str] = {}
    try:
        with services.engine.connect() as connection:
            connection.execute(text("SELECT 1"))
        checks["database"] = "ok"
    except Exception as error:
        log.warning("readyz: database unreachable: %s", error)
        return _not_ready({"database": "unreachable"}, "database unreachable")
    checks["migrations"] = "ok" if is_at_head(services.engine) else "not at head"
    try:
        checks["index"] = _index_check(services, request.app.state) or "ok"
    except Exception as error:
        log.warning("readyz: index check failed: %s", error)
        checks["index"] = f"check failed: {error}"
    failed = {name: state for name, state in checks.items() if state != "ok"}
    if failed:
        return _not_ready(checks, "; ".join(f"{name}: {state}" for name, state in failed.items()))
    return Health(status="ok", checks=checks)


def _not_ready(checks: dict[str, str], detail: str) -> JSONResponse:
    return problem_response(problem("not-ready", detail, checks=checks))
