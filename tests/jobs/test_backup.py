"""``shapesearch backup``: a copy taken while the service runs restores the whole service
(models, stored files and revisions, and the same answers), and a backup never leaves a
half-written or overwritten file behind."""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import create_engine, text
from sqlalchemy.engine import make_url

from app.api.main import create_app
from app.cli import main
from app.cli.backup import BackupError, backup_postgres, backup_sqlite
from tests.api.test_plm_models import wait_for_job
from tests.conftest import PARTS, fake_describe, make_settings, upload, wait_for_status

FILES = [PARTS / "20mm-xyz-cube.stl", PARTS / "cylinder.stl", PARTS / "angle_block.STL"]


def started(database: Path) -> TestClient:
    return started_on(f"sqlite:///{database}")


def started_on(url: str) -> TestClient:
    settings = make_settings(url)
    app = create_app(settings, embedded_worker=True, job_handler=fake_describe)
    client = TestClient(app, raise_server_exceptions=False)
    client.__enter__()
    return client


def catalogue(client: TestClient) -> dict[str, Any]:
    """What a restore must bring back: every model, its stored file, its revisions and its
    answers."""
    models = client.get("/v1/models", params={"limit": 100}).json()["items"]
    return {
        model["id"]: {
            "status": model["status"],
            "external_id": model["external_id"],
            "file": client.get(f"/v1/models/{model['id']}/file").content,
            "revisions": [
                (revision["number"], revision["status"])
                for revision in client.get(f"/v1/models/{model['id']}/revisions").json()["items"]
            ],
            "similar": [
                (hit["model"]["id"], round(hit["score"], 6))
                for hit in client.get(f"/v1/models/{model['id']}/similar").json()["results"]
            ],
        }
        for model in models
    }


def fill(client: TestClient) -> dict[str, Any]:
    """Three parts, one with a second revision (the backup must hold both files); the
    catalogue then."""
    for path in FILES:
        wait_for_status(client, upload(client, path, external_id=path.stem).json()["id"])
    changed = client.put(
        f"/v1/models/by-external-id/{FILES[0].stem}",
        files={"file": (FILES[1].name, FILES[1].read_bytes())},
    )
    assert changed.status_code == 202, changed.text
    # The model stays ready meanwhile: wait for the revision's job itself.
    assert wait_for_job(client, changed.json()["job"]["id"])["status"] == "done"
    return catalogue(client)


@pytest.mark.slow
def test_a_backup_taken_while_serving_restores_the_whole_service(tmp_path: Path) -> None:
    live = tmp_path / "live" / "shapesearch.db"
    client = started(live)
    try:
        before = fill(client)
        (tmp_path / "backups").mkdir()
        made = backup_sqlite(live, tmp_path / "backups")  # a directory: a time-stamped file
    finally:
        client.__exit__(None, None, None)

    assert made.path.parent == tmp_path / "backups" and made.path.name.startswith("shapesearch-")
    assert made.models_by_status == {"ready": 3}
    assert [path.name for path in made.path.parent.iterdir()] == [made.path.name]

    restored = tmp_path / "restored" / "shapesearch.db"
    restored.parent.mkdir()
    shutil.copyfile(made.path, restored)
    client = started(restored)
    try:
        after = catalogue(client)
    finally:
        client.__exit__(None, None, None)
    assert after == before
    assert sorted(model["revisions"] for model in after.values()) == [
        [(1, "current")], [(1, "current")], [(2, "current"), (1, "superseded")]
    ]
    assert all(model["similar"] for model in after.values())  # the index was rebuilt


def test_a_backup_never_overwrites_and_never_leaves_a_partial_file(tmp_path: Path) -> None:
    source = tmp_path / "shapesearch.db"
    started(source).__exit__(None, None, None)  # a migrated, empty database
    existing = tmp_path / "old-backup.db"
    existing.write_bytes(b"last week's backup")

    with pytest.raises(BackupError, match="exists"):
        backup_sqlite(source, existing)
    assert existing.read_bytes() == b"last week's backup"
    with pytest.raises(BackupError, match="no database"):
        backup_sqlite(tmp_path / "absent.db", tmp_path / "new.db")
    with pytest.raises(BackupError, match="failed"):  # the copy cannot be written there
        backup_sqlite(source, tmp_path / "no-such-folder" / "new.db")
    assert sorted(path.name for path in tmp_path.iterdir()) == ["old-backup.db", "shapesearch.db"]


def test_the_command_backs_up_sqlite(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    data = tmp_path / "data"
    started(data / "shapesearch.db").__exit__(None, None, None)
    monkeypatch.delenv("SHAPESEARCH_DATABASE_URL", raising=False)
    monkeypatch.setenv("SHAPESEARCH_DATA_DIR", str(data))
    assert main(["backup", str(tmp_path / "copy.db")]) == 0
    out, err = capsys.readouterr()
    assert out.strip() == str(tmp_path / "copy.db") and "integrity check ok" in err
    assert main(["backup", str(tmp_path / "copy.db")]) == 2  # never overwritten


def postgres_tools() -> None:
    """pg_dump and pg_restore, or a skip (a failure on CI, whose .ci/run installs them)."""
    if shutil.which("pg_dump") and shutil.which("pg_restore"):
        return
    if os.environ.get("CI") == "true":
        pytest.fail("pg_dump and pg_restore must be installed on CI (.ci/run)")
    pytest.skip("PostgreSQL's backup needs pg_dump and pg_restore (postgresql-client)")


@pytest.mark.slow
def test_a_postgresql_backup_taken_while_serving_restores_the_whole_service(
    tmp_path: Path, new_database_url: Callable[[str], str],
) -> None:
    """The dump of a service's schema, taken while it serves, dropped and restored with
    pg_restore as the README says, brings back every model, file, revision and answer."""
    postgres_tools()
    url = new_database_url("postgresql")
    client = started_on(url)
    try:
        before = fill(client)
        made = backup_postgres(make_url(url), tmp_path)
    finally:
        client.__exit__(None, None, None)
    assert made.path.suffix == ".dump" and made.models_by_status == {"ready": 3}
    assert [path.name for path in tmp_path.iterdir()] == [made.path.name]

    schema = make_url(url).query["options"].split("=", 1)[1]
    engine = create_engine(url, isolation_level="AUTOCOMMIT")
    with engine.connect() as connection:
        connection.execute(text(f'DROP SCHEMA "{schema}" CASCADE'))  # the database is lost
    engine.dispose()
    server = make_url(url).set(drivername="postgresql", query={})
    restore = subprocess.run(
        ["pg_restore", "--clean", "--if-exists", "--no-owner",
         f"--dbname={server.render_as_string(hide_password=False)}", str(made.path)],
        capture_output=True, text=True, check=False,
    )
    assert restore.returncode == 0, restore.stderr
    client = started_on(url)
    try:
        assert catalogue(client) == before
    finally:
        client.__exit__(None, None, None)


@pytest.mark.slow
def test_the_command_backs_up_postgresql_and_says_why_it_could_not(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    new_database_url: Callable[[str], str],
) -> None:
    postgres_tools()
    url = new_database_url("postgresql")
    started_on(url).__exit__(None, None, None)  # a migrated, empty database
    monkeypatch.setenv("SHAPESEARCH_DATABASE_URL", url)
    assert main(["backup", str(tmp_path)]) == 0
    out, err = capsys.readouterr()
    assert Path(out.strip()).parent == tmp_path and "archive read back ok" in err
    assert "0 model(s)" in err

    monkeypatch.setenv("SHAPESEARCH_DATABASE_URL", "postgresql+psycopg://nobody@127.0.0.1:1/x")
    assert main(["backup", str(tmp_path / "unreachable.dump")]) == 2
    assert "failed" in capsys.readouterr().err
    assert sorted(path.suffix for path in tmp_path.iterdir()) == [".dump"]  # nothing partial
    monkeypatch.setenv("PATH", str(tmp_path))  # no pg_dump here
    monkeypatch.setenv("SHAPESEARCH_DATABASE_URL", url)
    assert main(["backup", str(tmp_path / "no-tools.dump")]) == 2
    assert "pg_dump and pg_restore not found" in capsys.readouterr().err
