"""Who is calling: the tenant of the ``Authorization: Bearer`` key.

With no key in the database (and SHAPESEARCH_REQUIRE_API_KEYS unset) the service is open
and every caller is the tenant "default"; ``serve`` then only binds to loopback.

Lookups are cached per process for ``auth_cache_seconds`` (default 5 s), so a hot key costs
no database query and no thread-pool hop; a revoked key therefore stops working within
that time. Whether a service without keys is open is cached the same way: asking the
database on every request cost an open service 15% of its request time, and its first key
is required within that time (an open service only listens on loopback).
"""

from __future__ import annotations

import threading
import time
from typing import Annotated

from fastapi import Depends, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from app.api.deps import Services, ServicesDep
from app.api.problems import Problem
from app.auth.keys import DEFAULT_TENANT, keys_exist, tenant_for_key

__all__ = ["OPEN", "TenantDep", "current_tenant"]

_bearer = HTTPBearer(
    auto_error=False,
    description="An API key from `shapesearch keys create --tenant NAME`.",
)


def _unauthorized(detail: str) -> Problem:
    return Problem(
        "unauthorized",
        detail,
        headers={"WWW-Authenticate": 'Bearer realm="shapesearch"'},
    )


_CACHE_MAX = 10_000  # entries; the cache is cleared when full, so it never grows unbounded
OPEN = "\0open"  # cache key of the answer for a request without credentials


class _LookupCache:
    """token -> (tenant or None, expiry); ``OPEN`` -> whether keys are needed at all."""

    def __init__(self) -> None:
        self._entries: dict[str, tuple[str | None, float]] = {}
        self._lock = threading.Lock()

    def get(self, token: str) -> tuple[bool, str | None]:
        with self._lock:
            entry = self._entries.get(token)
        if entry is None or entry[1] < time.monotonic():
            return False, None
        return True, entry[0]

    def put(self, token: str, tenant: str | None, seconds: float) -> None:
        with self._lock:
            if len(self._entries) >= _CACHE_MAX:
                self._entries.clear()
            self._entries[token] = (tenant, time.monotonic() + seconds)


def _cache(request: Request) -> _LookupCache:
    """The app's cache (one per app instance, on ``app.state``)."""
    state = request.app.state
    if not hasattr(state, "auth_cache"):
        state.auth_cache = _LookupCache()
    return state.auth_cache


def _lookup(services: Services, token: str) -> str | None:
    """The tenant of ``token`` (``OPEN``: "default" if no key is needed, else None)."""
    with services.sessions() as session:
        if token == OPEN:
            needed = services.settings.require_api_keys or keys_exist(session)
            return None if needed else DEFAULT_TENANT
        return tenant_for_key(session, token)


async def current_tenant(
    request: Request,
    credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)],
    services: ServicesDep,
) -> str:
    token = OPEN if credentials is None else credentials.credentials
    cache = _cache(request)
    hit, tenant = cache.get(token)
    if not hit:
        tenant = await run_in_threadpool(_lookup, services, token)
        cache.put(token, tenant, services.settings.auth_cache_seconds)
    if tenant is None:
        if credentials is None:
            raise _unauthorized("This service needs an API key: Authorization: Bearer KEY.")
        raise _unauthorized("The API key is not valid.")
    return tenant


TenantDep = Annotated[str, Depends(current_tenant)]
