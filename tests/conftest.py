"""Shared fixtures of the service tests: databases on both backends, apps, fake describers.

Every test that asks for ``database_url`` runs twice, on SQLite and on PostgreSQL, each
time on a database of its own: a new SQLite file, or a new schema ``shapesearch_test_<hex>``
(selected by ``search_path``) in the database at SHAPESEARCH_TEST_POSTGRES_URL, by default
the local ``test`` database with trust auth; the schemas are dropped at the end.
Without a reachable PostgreSQL the PostgreSQL half is skipped, except on CI (CI=true),
where that is a failure.
"""

from __future__ import annotations

import hashlib
import os
import secrets
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from sqlalchemy import create_engine, select, text
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session, sessionmaker

from app.db.migrate import upgrade
from app.db.models import FeedState
from app.db.session import make_engine, make_session_factory
from app.ingest.describing import size_columns
from app.settings import Settings
from core.cutoff import CutoffRecord

PARTS = Path(__file__).parent / "fixtures" / "parts"
EDGE_CASES = PARTS / "edge_cases"
POSTGRES_URL = os.environ.get(
    "SHAPESEARCH_TEST_POSTGRES_URL", "postgresql+psycopg://postgres@127.0.0.1:5432/test"
)

# Small engine settings: the whole suite describes a few dozen parts on 2 shared cores.
SMALL_ENGINE = {
    "max_points": 1500,
    "upload_check_points": 300,
    "cutoff_seed": 20,
    "cutoff_n_min": 30,
    "cutoff_n_max": 120,
}
# Fast queue timings so that waiting for workers costs little.
FAST_QUEUE = {"poll_interval": 0.05, "index_sync_interval": 0.2, "shutdown_grace_seconds": 10}


class _Postgres:
    """Creates and drops the per-test schemas on the test server.

    Each test database is a fresh schema, selected with ``search_path`` in the URL: as
    isolated as a database for this service, and far cheaper to create and drop.
    """

    def __init__(self, url: str) -> None:
        self.url = make_url(url)
        self.admin = create_engine(url, isolation_level="AUTOCOMMIT", pool_pre_ping=True)
        self.created: list[str] = []

    def reachable(self) -> str | None:
        try:
            with self.admin.connect() as connection:
                connection.execute(text("SELECT 1"))
        except Exception as error:
            return f"PostgreSQL at {self.url.render_as_string()} is not reachable: {error}"
        return None

    def new_database(self) -> str:
        name = f"shapesearch_test_{secrets.token_hex(5)}"
        with self.admin.connect() as connection:
            connection.execute(text(f'CREATE SCHEMA "{name}"'))
        self.created.append(name)
        url = self.url.update_query_dict({"options": f"-csearch_path={name}"})
        return url.render_as_string(hide_password=False)

    def drop_all(self) -> None:
        with self.admin.connect() as connection:
            for name in self.created:
                connection.execute(text(f'DROP SCHEMA IF EXISTS "{name}" CASCADE'))
        self.admin.dispose()


@pytest.fixture(scope="session")
def postgres() -> Iterator[_Postgres | None]:
    server = _Postgres(POSTGRES_URL)
    problem = server.reachable()
    if problem is not None:
        server.admin.dispose()
        yield None
        return
    yield server
    server.drop_all()


def _require(postgres: _Postgres | None) -> _Postgres:
    if postgres is None:
        reason = f"PostgreSQL tests need a server at {POSTGRES_URL}"
        if os.environ.get("CI") == "true":
            pytest.fail(f"{reason}, and CI=true: PostgreSQL must be reachable on CI")
        pytest.skip(f"{reason}: not reachable (set SHAPESEARCH_TEST_POSTGRES_URL)")
    return postgres


@pytest.fixture
def new_database_url(
    request: pytest.FixtureRequest,
    tmp_path_factory: pytest.TempPathFactory,
    postgres: _Postgres | None,
) -> Callable[[str], str]:
    """``new(backend)``: the URL of a fresh, empty database on that backend."""

    def new(backend: str) -> str:
        if backend == "sqlite":
            return f"sqlite:///{tmp_path_factory.mktemp('db') / 'shapesearch.db'}"
        return _require(postgres).new_database()

    return new


@pytest.fixture(params=["sqlite", "postgresql"])
def backend(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture
def database_url(backend: str, new_database_url: Callable[[str], str]) -> str:
    return new_database_url(backend)


@pytest.fixture
def sessions(database_url: str) -> Iterator[sessionmaker[Session]]:
    """A session factory on a fresh, migrated database of each backend."""
    engine = make_engine(database_url)
    upgrade(engine)
    yield make_session_factory(engine)
    engine.dispose()


def make_settings(database_url: str, **overrides: Any) -> Settings:
    values: dict[str, Any] = {"database_url": database_url, **SMALL_ENGINE, **FAST_QUEUE}
    values.update(overrides)
    return Settings(**values)


def fake_describe(content: bytes, filename: str) -> dict[str, Any]:
    """A stand-in for the engine, for tests of the service machinery: instant, and equal
    files get equal unit descriptors."""
    seed = int.from_bytes(hashlib.sha256(content).digest()[:8], "little")
    vector = np.random.default_rng(seed).normal(size=16).astype(np.float32)
    vector /= np.linalg.norm(vector)
    return {
        "n_points": 100,
        "cutoff": CutoffRecord(
            mode="adaptive", n=10, solver_calls=2, predicted=[10], xi=1e-10, t=1e-3,
            n_min=5, n_max=20,
        ).to_json(),
        "eigenvalues": [float(i) for i in range(10)],
        "descriptor": vector.tobytes(),
        "descriptor_version": "fake-1",
        "timings": {"total": 0.0},
        **size_columns(None),  # no size: like a model described before sizes existed
    }


def wait_for_status(
    client: TestClient,
    model_id: str,
    statuses: tuple[str, ...] = ("ready", "failed"),
    timeout: float = 120.0,
    headers: dict[str, str] | None = None,
) -> dict[str, Any]:
    """Poll GET /v1/models/{id} until its status is one of ``statuses``; a ready model is
    then awaited in the serving process's index too (``wait_until_indexed``)."""
    deadline = time.monotonic() + timeout
    while True:
        body = client.get(f"/v1/models/{model_id}", headers=headers).json()
        if body.get("status") in statuses:
            if body["status"] == "ready":
                wait_until_indexed(client, deadline - time.monotonic())
            return body
        if time.monotonic() > deadline:
            raise AssertionError(f"model {model_id} still {body.get('status')} after {timeout}s")
        time.sleep(0.05)


def wait_until_indexed(client: TestClient, timeout: float = 30.0) -> None:
    """Wait until the index of ``client``'s process has applied the change feed up to its
    newest event. A model reads "ready" as its transaction commits; the worker's sync (or
    the feed's follower) adds it to the index a moment later, longer on a loaded machine with
    Milvus's writes: a search in between would not find it yet. Waits, never syncs itself,
    so a process that stopped following the feed still fails the test."""
    services = getattr(client.app.state, "services", None)  # type: ignore[attr-defined]
    if services is None:
        return
    with services.sessions() as session:
        head = session.scalar(select(FeedState.revision).where(FeedState.id == 1))
    deadline = time.monotonic() + max(timeout, 1.0)
    while services.index.revision < (head or 0):
        if time.monotonic() > deadline:
            raise AssertionError(f"index at revision {services.index.revision}, feed at {head}")
        time.sleep(0.01)


def stored_duplicates(client: TestClient, limit: int = 50, **params: Any) -> dict[str, Any]:
    """POST /v1/duplicates with ``params``, wait for its job, then GET the first page of
    the stored report with the same parameters."""
    posted = client.post("/v1/duplicates", json=params)
    assert posted.status_code == 202, posted.text
    job = posted.json()
    assert job["kind"] == "duplicates" and job["model_id"] is None
    assert posted.headers["Location"] == f"/v1/jobs/{job['id']}"
    deadline = time.monotonic() + 120
    while (job := client.get(f"/v1/jobs/{job['id']}").json())["status"] not in ("done", "failed"):
        assert time.monotonic() < deadline, job
        time.sleep(0.05)
    assert job["status"] == "done", job
    page = client.get("/v1/duplicates", params={**params, "limit": limit})
    assert page.status_code == 200, page.text
    assert page.json()["job_id"] == job["id"]
    return dict(page.json())


def upload(
    client: TestClient,
    path: Path,
    *,
    filename: str | None = None,
    headers: dict[str, str] | None = None,
    **form: str,
) -> Any:
    """POST /v1/models with the file at ``path``."""
    return client.post(
        "/v1/models",
        files={"file": (filename or path.name, path.read_bytes(), "application/octet-stream")},
        data=form,
        headers=headers,
    )
