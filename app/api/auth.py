"""Who is calling: the tenant of the ``Authorization: Bearer`` key.

With no key in the database (and SHAPESEARCH_REQUIRE_API_KEYS unset) the service is open
and every caller is the tenant "default"; ``serve`` then only binds to loopback.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from app.api.deps import ServicesDep
from app.api.problems import Problem
from app.keys import DEFAULT_TENANT, keys_exist, tenant_for_key

__all__ = ["TenantDep", "current_tenant"]

_bearer = HTTPBearer(
    auto_error=False,
    description="An API key from `shapesearch keys create --tenant NAME`.",
)


def _unauthorized(detail: str) -> Problem:
    return Problem(
        401,
        detail,
        slug="unauthorized",
        headers={"WWW-Authenticate": 'Bearer realm="shapesearch"'},
    )


def current_tenant(
    credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)],
    services: ServicesDep,
) -> str:
    with services.sessions() as session:
        if credentials is None:
            if services.settings.require_api_keys or keys_exist(session):
                raise _unauthorized("This service needs an API key: Authorization: Bearer KEY.")
            return DEFAULT_TENANT
        tenant = tenant_for_key(session, credentials.credentials)
    if tenant is None:
        raise _unauthorized("The API key is not valid.")
    return tenant


TenantDep = Annotated[str, Depends(current_tenant)]
