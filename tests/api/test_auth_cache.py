"""Key lookups are cached per process for auth_cache_seconds: a revoked key stops working
within that bound, and so does an open service once its first key exists."""

from __future__ import annotations

import time

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import create_engine, delete

from app.api.main import create_app
from app.auth.keys import create_key
from app.db.models import ApiKey
from app.db.session import make_session_factory
from tests.conftest import make_settings

CACHE_SECONDS = 2.0


@pytest.mark.slow
def test_a_revoked_key_stops_working_within_the_cache_time(database_url: str) -> None:
    app = create_app(make_settings(database_url, auth_cache_seconds=CACHE_SECONDS))
    with TestClient(app) as client:
        assert client.get("/v1/models").status_code == 200  # open: no key yet
        engine = create_engine(database_url)
        with make_session_factory(engine).begin() as session:
            headers = {"Authorization": f"Bearer {create_key(session, 'alice')}"}
        created_at = time.monotonic()
        # "Open" is cached like any lookup: the first key is required within CACHE_SECONDS.
        while client.get("/v1/models").status_code == 200:
            assert time.monotonic() - created_at < CACHE_SECONDS + 1.0
            time.sleep(0.05)
        assert client.get("/v1/models").status_code == 401
        assert client.get("/v1/models", headers=headers).status_code == 200

        with engine.begin() as connection:
            connection.execute(delete(ApiKey))  # revoke
        engine.dispose()
        revoked_at = time.monotonic()
        # Served from the cache (no lookup per request) for at most CACHE_SECONDS, then refused.
        assert client.get("/v1/models", headers=headers).status_code == 200
        while client.get("/v1/models", headers=headers).status_code == 200:
            assert time.monotonic() - revoked_at < CACHE_SECONDS + 1.0
            time.sleep(0.05)
        assert client.get("/v1/models", headers=headers).status_code == 401
