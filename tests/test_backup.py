"""``shapesearch backup``: a copy taken while the service runs restores the whole service
(models, stored files and revisions, and the same answers), and a backup never leaves a
half-written or overwritten file behind."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest
from conftest import PARTS, fake_describe, make_settings, upload, wait_for_status
from fastapi.testclient import TestClient
from test_plm_models import wait_for_job

from app.api.main import create_app
from app.cli import main
from app.cli.backup import BackupError, backup_sqlite

FILES = [PARTS / "20mm-xyz-cube.stl", PARTS / "cylinder.stl", PARTS / "angle_block.STL"]


def started(database: Path) -> TestClient:
    settings = make_settings(f"sqlite:///{database}")
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


def test_a_backup_taken_while_serving_restores_the_whole_service(tmp_path: Path) -> None:
    live = tmp_path / "live" / "shapesearch.db"
    client = started(live)
    try:
        for path in FILES:
            wait_for_status(client, upload(client, path, external_id=path.stem).json()["id"])
        # A second revision of one part: the backup must hold both files.
        changed = client.put(
            f"/v1/models/by-external-id/{FILES[0].stem}",
            files={"file": (FILES[1].name, FILES[1].read_bytes())},
        )
        assert changed.status_code == 202, changed.text
        # The model stays ready meanwhile: wait for the revision's job itself.
        assert wait_for_job(client, changed.json()["job"]["id"])["status"] == "done"
        before = catalogue(client)
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


def test_the_command_backs_up_sqlite_and_points_postgresql_to_pg_dump(
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

    monkeypatch.setenv("SHAPESEARCH_DATABASE_URL", "postgresql+psycopg://shapesearch@db:5432/parts")
    assert main(["backup", str(tmp_path / "pg.db")]) == 2
    err = capsys.readouterr().err
    assert "pg_dump --format=custom --host db --username shapesearch" in err and "parts" in err
    assert not (tmp_path / "pg.db").exists()
