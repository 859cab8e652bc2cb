"""``shapesearch keys list|revoke`` and ``shapesearch redescribe`` on both backends; the
re-describe test runs the real engine (small settings) because versions are the point."""

from __future__ import annotations

import time
from typing import Any

import pytest
from fastapi.testclient import TestClient

from app.api.main import create_app
from app.cli import main
from tests.conftest import PARTS, SMALL_ENGINE, make_settings, upload, wait_for_status

PARTS_USED = ["20mm-xyz-cube.stl", "cylinder.stl", "angle_block.STL"]


def use_database(monkeypatch: pytest.MonkeyPatch, database_url: str, **settings: Any) -> None:
    monkeypatch.setenv("SHAPESEARCH_DATABASE_URL", database_url)
    for name, value in settings.items():
        monkeypatch.setenv(f"SHAPESEARCH_{name.upper()}", str(value))


@pytest.mark.slow
def test_keys_are_listed_and_revoked(
    database_url: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    use_database(monkeypatch, database_url)
    assert main(["keys", "create", "--tenant", "acme"]) == 0
    key = capsys.readouterr().out.strip()
    assert main(["keys", "create", "--tenant", "globex"]) == 0
    other = capsys.readouterr().out.strip()
    assert main(["keys", "list"]) == 0
    listing = capsys.readouterr().out
    assert key[:15] in listing and "acme" in listing and other[:15] in listing
    assert key[15:] not in listing  # never the secret part

    cache_seconds = 0.5
    settings = make_settings(database_url, workers=0, auth_cache_seconds=cache_seconds)
    with TestClient(create_app(settings)) as client:
        bearer = {"Authorization": f"Bearer {key}"}
        assert client.get("/v1/models", headers=bearer).status_code == 200
        assert main(["keys", "revoke", key[:15]]) == 0
        # Another process revoked it: this API process stops accepting it within its auth cache.
        deadline = time.monotonic() + cache_seconds + 2.0
        while client.get("/v1/models", headers=bearer).status_code != 401:
            assert time.monotonic() < deadline, "a revoked key still works past the auth cache"
            time.sleep(0.05)
        other_bearer = {"Authorization": f"Bearer {other}"}
        assert client.get("/v1/models", headers=other_bearer).status_code == 200
    assert main(["keys", "revoke", key[:15]]) == 1
    assert "no key" in capsys.readouterr().err


@pytest.mark.slow
def test_redescribe_moves_every_model_to_the_new_version(
    database_url: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    old_app = create_app(make_settings(database_url, workers=1), embedded_worker=True)
    with TestClient(old_app) as client:
        ids = [upload(client, PARTS / name, external_id=name).json()["id"] for name in PARTS_USED]
        old = [wait_for_status(client, model_id, timeout=300) for model_id in ids]
    assert {m["status"] for m in old} == {"ready"}
    old_version = old[0]["descriptor_version"]
    scan = (PARTS / "cylinder.stl").read_bytes()

    changed = {**SMALL_ENGINE, "descriptor_bins": 12}
    new_app = create_app(make_settings(database_url, workers=1, **changed), embedded_worker=True)
    with TestClient(new_app) as client:
        stats = client.get("/v1/stats").json()
        new_version = stats["current_descriptor_version"]
        assert new_version != old_version and stats["by_descriptor_version"] == {old_version: 3}
        found = client.post("/v1/search", files={"file": ("q.stl", scan)}).json()
        assert found["results"] == []  # the old descriptors are not comparable

        use_database(monkeypatch, database_url, **changed)
        assert main(["redescribe"]) == 0
        deadline = time.monotonic() + 300
        while client.get("/v1/stats").json()["by_descriptor_version"] != {new_version: 3}:
            assert time.monotonic() < deadline, client.get("/v1/stats").json()
            time.sleep(0.2)
        jobs = client.get("/v1/jobs", params={"status": "done"}).json()["items"]
        assert len(jobs) == 6
        found = client.post("/v1/search", params={"k": 3},
                            files={"file": ("q.stl", scan)}).json()
        assert found["results"][0]["model"]["external_id"] == "cylinder.stl"
        assert found["query"]["descriptor_version"] == new_version
        assert main(["redescribe"]) == 0  # nothing left to move
        time.sleep(0.3)
        assert client.get("/v1/jobs", params={"status": "queued"}).json()["items"] == []
