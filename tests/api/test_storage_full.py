"""Full storage: recognised wherever it surfaces, answered 507, never blamed on the file,
and never allowed to spend a job's attempts.

The full disks here are real ones, made small: SQLite's ``max_page_count`` (SQLite then
answers ``SQLITE_FULL`` exactly as on a full disk) and ``/dev/full`` (every write fails with
``ENOSPC`` from the kernel) standing in for a temporary file's disk. PostgreSQL's
``disk_full`` cannot be provoked without filling the server's disk; its class is checked.
"""

from __future__ import annotations

import errno
import os
import tempfile
import threading
from collections.abc import Callable, Iterator
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import psycopg.errors
import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine, create_engine, event, select, text
from sqlalchemy.exc import OperationalError
from sqlalchemy.orm import Session, sessionmaker

from app.api.main import create_app
from app.db.migrate import upgrade
from app.db.models import Job, Model
from app.db.session import make_engine, make_session_factory
from app.ingest.sandbox import Sandbox
from app.jobs.worker import STORAGE_FULL_DELAY_SECONDS, Worker
from app.storage import storage_full
from core.errors import InvalidShapeError
from core.io import load_points
from tests.conftest import PARTS, fake_describe, make_settings, upload, wait_for_status
from tests.hostile_files import step_part
from tests.jobs.test_database_outage import locked_database_error
from tests.jobs.test_queue import RESULT, add_jobs, make_queue

CUBE = PARTS / "20mm-xyz-cube.stl"
CYLINDER = PARTS / "cylinder.stl"
FULL_DEVICE = Path("/dev/full")

pytestmark = pytest.mark.skipif(not FULL_DEVICE.exists(), reason="needs /dev/full (Linux)")


def write_to_a_full_disk() -> None:
    """Raise the kernel's own ENOSPC."""
    with FULL_DEVICE.open("wb", buffering=0) as device:
        device.write(b"part")


def cap_growth(engine: Engine) -> Callable[[], None]:
    """From now on, ``engine``'s SQLite database cannot grow (``SQLITE_FULL`` on any write
    that needs a new page); returns the function that lifts the cap."""

    def cap(connection: Any, _record: Any) -> None:
        cursor = connection.cursor()
        pages = cursor.execute("PRAGMA page_count").fetchone()[0]
        cursor.execute(f"PRAGMA max_page_count = {pages}")
        cursor.close()

    event.listen(engine, "connect", cap)
    engine.dispose()  # pooled connections come back capped

    def lift() -> None:
        event.remove(engine, "connect", cap)
        engine.dispose()

    return lift


def sqlite_full_error(tmp_path: Path) -> OperationalError:
    engine = create_engine(f"sqlite:///{tmp_path / 'full.db'}")
    with engine.begin() as connection:
        connection.execute(text("CREATE TABLE blobs (data BLOB)"))
    cap_growth(engine)
    with pytest.raises(OperationalError) as raised, engine.begin() as connection:
        connection.execute(text("INSERT INTO blobs VALUES (:data)"), {"data": b"x" * 100_000})
    engine.dispose()
    return raised.value


def test_storage_full_is_told_apart_from_other_errors(tmp_path: Path) -> None:
    full_database = sqlite_full_error(tmp_path)
    assert "full" in str(full_database)
    assert storage_full(full_database)  # SQLAlchemy's wrapper of sqlite3's SQLITE_FULL
    assert storage_full(full_database.orig)

    with pytest.raises(OSError) as no_space:
        write_to_a_full_disk()
    assert no_space.value.errno == errno.ENOSPC and storage_full(no_space.value)
    try:  # however deep a library wrapped it
        try:
            write_to_a_full_disk()
        except OSError as error:
            raise RuntimeError("could not spool the upload") from error
    except RuntimeError as wrapped:
        assert storage_full(wrapped)
    try:  # but a bug met while handling a full disk is a bug
        try:
            write_to_a_full_disk()
        except OSError:
            raise ValueError("a bug in the handler")  # noqa: B904
    except ValueError as unrelated:
        assert unrelated.__context__ is not None and not storage_full(unrelated)

    assert storage_full(psycopg.errors.DiskFull("could not extend file"))

    # A busy database, a missing file, a constraint, a bug: not full.
    assert not storage_full(locked_database_error(tmp_path))
    with pytest.raises(OSError) as missing:
        (tmp_path / "absent").read_bytes()
    assert not storage_full(missing.value)
    assert not storage_full(psycopg.errors.UniqueViolation("duplicate key"))
    assert not storage_full(ValueError("a bug"))


# --- the API ------------------------------------------------------------------------------


@pytest.fixture
def client(new_database_url: Callable[[str], str]) -> Iterator[TestClient]:
    settings = make_settings(new_database_url("sqlite"))
    app = create_app(settings, embedded_worker=True, job_handler=fake_describe)
    with TestClient(app, raise_server_exceptions=False) as started:
        yield started


def assert_storage_full(response: Any) -> None:
    assert response.status_code == 507, response.text
    assert response.headers["content-type"].startswith("application/problem+json")
    assert response.json()["type"] == "urn:shapesearch:problem:storage-full"
    assert int(response.headers["retry-after"]) > 0


@pytest.mark.slow
def test_a_full_database_refuses_writes_with_507_and_keeps_answering_reads(
    client: TestClient,
) -> None:
    first = upload(client, CUBE).json()
    wait_for_status(client, first["id"])
    lift = cap_growth(client.app.state.services.engine)  # type: ignore[attr-defined]

    assert_storage_full(upload(client, CYLINDER))  # was 500 internal-error
    assert client.get("/v1/models").json()["items"][0]["id"] == first["id"]
    assert client.get(f"/v1/models/{first['id']}/similar").status_code == 200

    lift()
    second = upload(client, CYLINDER)
    assert second.status_code == 202, second.text
    assert wait_for_status(client, second.json()["id"])["status"] == "ready"
    # The refused upload left nothing behind: two models, both ready.
    models = client.get("/v1/models").json()["items"]
    assert sorted(model["status"] for model in models) == ["ready", "ready"]


def test_an_upload_that_cannot_be_spooled_is_507_not_a_malformed_body(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A part over the multipart parser's 1 MB in memory goes to a temporary file; here
    # that file's disk is full (it was 400 "There was an error parsing the body").
    monkeypatch.setattr(tempfile, "TemporaryFile", lambda *args, **kwargs: FULL_DEVICE.open("w+b"))
    large = b"solid big\n" + b"  \n" * 600_000 + b"endsolid big\n"
    response = client.post("/v1/models", files={"file": ("big.stl", large)})
    assert_storage_full(response)


# --- readers and the sandbox ----------------------------------------------------------------


def test_a_readers_copy_on_a_full_disk_is_not_called_unparsable(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # OpenCascade reads STEP from a path: its temporary copy lands on a full disk.
    pytest.importorskip("OCP", reason="STEP needs the cad extra")
    copy = tmp_path / "copy.step"
    copy.symlink_to(FULL_DEVICE)
    monkeypatch.setattr(
        "core.io._cad.tempfile.mkstemp", lambda suffix="": (os.open(copy, os.O_WRONLY), str(copy))
    )
    with pytest.raises(OSError) as raised:  # was InvalidShapeError("unparsable")
        load_points(step_part(), filename="part.step")
    assert not isinstance(raised.value, InvalidShapeError)
    assert raised.value.errno == errno.ENOSPC


@pytest.mark.slow
def test_the_sandbox_hands_a_full_disk_back_as_such() -> None:
    with pytest.raises(OSError) as raised:  # was SandboxCrash, a retried internal error
        Sandbox(1024**3, 60).run(write_to_a_full_disk)
    assert raised.value.errno == errno.ENOSPC and storage_full(raised.value)


# --- the worker ---------------------------------------------------------------------------


def test_a_job_that_meets_a_full_disk_waits_without_spending_an_attempt(
    sessions: sessionmaker[Session],
) -> None:
    add_jobs(sessions, 1)

    def handler(content: bytes, filename: str) -> dict[str, Any]:
        write_to_a_full_disk()
        raise AssertionError("unreachable")

    queue = make_queue(sessions, max_attempts=1)  # a retry would fail the job at once
    worker = Worker(queue, handler, worker_id="w", poll_interval=0.01, stop=threading.Event())
    before = datetime.now(UTC)
    assert worker.run_once()
    with sessions() as session:
        job, model_status = session.execute(select(Job, Model.status).join(Model)).one()
    assert job.status == "queued" and model_status == "queued"
    assert job.attempts == 0  # given back: was 1, and the job failed
    assert job.last_error["type"] == "urn:shapesearch:problem:storage-full"
    waited = (job.run_after - before).total_seconds()
    assert STORAGE_FULL_DELAY_SECONDS - 5 <= waited <= STORAGE_FULL_DELAY_SECONDS + 5
    assert not worker.run_once()  # not due before then, and the worker lives on


def test_a_result_that_finds_the_database_full_is_kept_for_later(
    new_database_url: Callable[[str], str],
) -> None:
    # The describe succeeded, but storing its descriptor needs pages the database cannot
    # grow: the job waits, its attempt given back, instead of running out its lease and
    # being taken over as if its worker had died.
    engine = make_engine(new_database_url("sqlite"))
    upgrade(engine)
    sessions = make_session_factory(engine)
    add_jobs(sessions, 1)
    lifts: list[Callable[[], None]] = []

    def handler(content: bytes, filename: str) -> dict[str, Any]:
        lifts.append(cap_growth(engine))  # the disk fills while the part is described
        return {**RESULT, "descriptor": os.urandom(200_000)}

    worker = Worker(make_queue(sessions), handler, worker_id="w", poll_interval=0.01,
                    stop=threading.Event())
    assert worker.run_once()
    with sessions() as session:
        job, status, descriptor = session.execute(
            select(Job, Model.status, Model.descriptor).join(Model)
        ).one()
    assert (job.status, job.attempts, status) == ("queued", 0, "queued")
    assert job.last_error["type"] == "urn:shapesearch:problem:storage-full"
    assert descriptor is None  # nothing half-stored
    lifts[0]()
    engine.dispose()
