"""GET /metrics: Prometheus text format (see ``app.observability.metrics``); with several API
processes one scrape sums all of them.

Only loopback clients are answered unless SHAPESEARCH_METRICS_FROM_ANYWHERE is set: the
metrics name tenants and sizes, which are not for every caller of a public API. (In open
mode the whole service listens on loopback only anyway.)
"""

from __future__ import annotations

from fastapi import APIRouter, Request, Response

from app.api.deps import ServicesDep
from app.api.problems import Problem, problem_responses
from app.net import is_loopback
from app.observability.metrics import CONTENT_TYPE_LATEST, exposition

__all__ = ["router"]

router = APIRouter(tags=["health"])


@router.get(
    "/metrics",
    response_class=Response,
    responses={
        200: {"description": "Prometheus text format", "content": {"text/plain": {}}},
        **problem_responses(403),
    },
    summary="Prometheus metrics (loopback clients only, unless configured otherwise)",
)
def metrics(request: Request, services: ServicesDep) -> Response:
    client = request.client.host if request.client else ""
    if not (services.settings.metrics_from_anywhere or is_loopback(client)):
        raise Problem(
            "forbidden",
            "/metrics answers loopback clients only (SHAPESEARCH_METRICS_FROM_ANYWHERE).",
        )
    return Response(exposition(request.app.state.metrics), media_type=CONTENT_TYPE_LATEST)
