"""A short way through the app for the two hot reads: a plain similar list and a catalogue
page.

FastAPI's routing and dependency solving (the tenant, its key, the search parameters, each a
dependency resolved per request) cost a similar request about as much as the whole of
``/healthz`` does. This ASGI middleware answers ``GET /v1/models/{id}/similar`` and
``GET /v1/models`` itself when the request is plainly valid: only the routes' simple
parameters (``k``, ``min_score``, ``mode``; ``limit``, ``status``, ``external_id``,
``cursor``), each once, in canonical form and within its bounds, and a key (or no key, on an
open service) that the auth cache (``app.auth.dependency``) holds for a tenant. It runs the
routes' own functions in the query pool and sends the same bytes they send. Anything else
(another parameter, a value FastAPI might read differently, a key to look up, an answer that
is an error) goes the usual way, through the routes, which then answer it (an error is
computed again there: a 404 or 409 costs two tries).

It sits inside the response cache (a hit never gets here; a miss answered here is kept) and
inside the metrics and logs, which label its answers with the route's template as FastAPI
would.
"""

from __future__ import annotations

import asyncio
import re
from urllib.parse import parse_qsl

from fastapi.security.utils import get_authorization_scheme_param
from starlette.responses import Response
from starlette.types import ASGIApp, Receive, Scope, Send

from app.api.answers import JSON
from app.api.cursors import keyset_after
from app.api.problems import Problem
from app.api.routes import models
from app.api.search_params import SizeOptions
from app.auth.dependency import OPEN
from app.search.similarity import SearchMode

__all__ = ["HotReads"]

_SIMILAR_PATH = re.compile(r"/v1/models/([^/]+)/similar")
_COUNT = re.compile(r"[1-9][0-9]{0,3}")  # a positive integer as a client writes it
_UNIT = re.compile(r"[01](?:\.[0-9]{1,17})?")  # 0, 1, 0.25 ...
_STATUSES = frozenset({"queued", "processing", "ready", "failed"})
_NO_SIZE = SizeOptions({}, None, 0.0)


class HotReads:
    """ASGI middleware; see the module docstring."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app
        by_name = {route.name: route for route in models.router.routes}  # type: ignore[attr-defined]
        self._similar_route = by_name["similar_models"]
        self._list_route = by_name["list_models"]

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope["method"] != "GET":
            await self.app(scope, receive, send)
            return
        path: str = scope["path"]
        if path == "/v1/models":
            handled = await self._list(scope, receive, send)
        elif path.endswith("/similar") and (match := _SIMILAR_PATH.fullmatch(path)):
            handled = await self._similar(scope, receive, send, match.group(1))
        else:
            handled = False
        if not handled:
            await self.app(scope, receive, send)

    async def _similar(self, scope: Scope, receive: Receive, send: Send, model_id: str) -> bool:
        query = _parameters(scope, ("k", "min_score", "mode"))
        tenant = _tenant(scope)
        if query is None or tenant is None:
            return False
        k = _count(query.get("k", "10"), 100)
        min_score = query.get("min_score")
        mode_asked = query.get("mode", "shape")
        if k is None or mode_asked not in ("shape", "scan") or (
                min_score is not None and _UNIT.fullmatch(min_score) is None):
            return False
        mode: SearchMode = "scan" if mode_asked == "scan" else "shape"
        score = None if min_score is None else float(min_score)
        if score is not None and score > 1.0:
            return False
        services = scope["app"].state.services
        try:
            body = await asyncio.get_running_loop().run_in_executor(
                services.queries, models.similar_json, services, tenant, model_id, k, score,
                {}, {}, mode, _NO_SIZE,
            )
        except Exception:  # a 404, 409, 503...: the route answers it
            return False
        scope["route"] = self._similar_route
        await Response(body, media_type=JSON)(scope, receive, send)
        return True

    async def _list(self, scope: Scope, receive: Receive, send: Send) -> bool:
        query = _parameters(scope, ("limit", "status", "external_id", "cursor"))
        tenant = _tenant(scope)
        if query is None or tenant is None:
            return False
        limit = _count(query.get("limit", "50"), 500)
        status = query.get("status")
        if limit is None or (status is not None and status not in _STATUSES):
            return False
        try:
            after = keyset_after(query.get("cursor", ""))
        except Problem:
            return False
        services = scope["app"].state.services
        kind, values = models.page_query(tenant, status, query.get("external_id"), after, limit)
        try:
            body = await asyncio.get_running_loop().run_in_executor(
                services.queries, models.page_json, services.reader, kind, values, limit
            )
        except Exception:  # the database unavailable...: the route answers it
            return False
        scope["route"] = self._list_route
        await Response(body, media_type=JSON)(scope, receive, send)
        return True


def _parameters(scope: Scope, known: tuple[str, ...]) -> dict[str, str] | None:
    """The query parameters, or None unless each is one of ``known``, given once, and not
    empty (as Starlette decodes them)."""
    raw: bytes = scope["query_string"]
    if not raw:
        return {}
    pairs = parse_qsl(raw.decode("latin-1"), keep_blank_values=True)
    found = dict(pairs)
    if len(found) != len(pairs) or not all(
            name in known and value for name, value in found.items()):
        return None
    return found


def _count(text: str, most: int) -> int | None:
    """``text`` as an integer in 1..``most`` written plainly, or None."""
    if _COUNT.fullmatch(text) is None:
        return None
    value = int(text)
    return value if value <= most else None


def _tenant(scope: Scope) -> str | None:
    """The caller's tenant as the auth cache holds it (``app.auth.dependency``), or None when
    it holds none yet (the route looks the key up) or refuses it (the route says 401)."""
    cache = getattr(scope["app"].state, "auth_cache", None)
    if cache is None:
        return None
    token = OPEN
    for name, value in scope["headers"]:
        if name == b"authorization":
            # HTTPBearer's reading: anything but "Bearer <key>" counts as no key.
            scheme, credentials = get_authorization_scheme_param(value.decode("latin-1"))
            if scheme and credentials and scheme.lower() == "bearer":
                token = credentials
            break
    hit, tenant = cache.get(token)
    return tenant if hit else None
