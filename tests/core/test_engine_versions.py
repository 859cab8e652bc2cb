"""The engine libraries' versions are part of descriptor_version: an upgrade of one of them
makes every stored model stale, as a change of setting does, and GET /v1/stats says so."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from importlib import metadata
from typing import Any

import pytest

from app.db.session import make_engine, make_session_factory
from app.ingest.redescribe import current_version, enqueue_models
from core.descriptor import ENGINE_LIBRARIES, DescriptorSpec, engine_library_versions
from core.settings import EngineSettings
from tests.conftest import PARTS, fake_describe, make_settings, upload, wait_for_status
from tests.plm_helpers import started_clients

Upgrade = Callable[[dict[str, str]], None]


@pytest.fixture
def upgrade(monkeypatch: pytest.MonkeyPatch) -> Iterator[Upgrade]:
    """``upgrade({name: version})``: from now on this process has those library versions
    installed (the others stay as they are)."""
    real = metadata.version
    overrides: dict[str, str] = {}

    def installed(name: str) -> str:
        return overrides.get(name) or real(name)

    def apply(versions: dict[str, str]) -> None:
        overrides.clear()
        overrides.update(versions)
        engine_library_versions.cache_clear()  # the versions are read once per process

    monkeypatch.setattr(metadata, "version", installed)
    yield apply
    engine_library_versions.cache_clear()  # before monkeypatch restores the real reader


def version_of(settings: EngineSettings) -> str:
    return DescriptorSpec.from_settings(settings.descriptor).version(settings)


def test_the_versions_are_the_installed_ones() -> None:
    versions = engine_library_versions()
    assert tuple(versions) == ENGINE_LIBRARIES
    assert versions == {name: metadata.version(name) for name in ENGINE_LIBRARIES}


def test_every_engine_library_upgrade_changes_the_descriptor_version(upgrade: Upgrade) -> None:
    settings = EngineSettings()
    before = version_of(settings)
    seen = {before}
    for name in ENGINE_LIBRARIES:
        upgrade({name: "999.0"})
        assert engine_library_versions()[name] == "999.0"
        after = version_of(settings)
        # The readable part names settings; the digest tells the libraries apart.
        assert after.rsplit(";", 1)[0] == before.rsplit(";", 1)[0]
        seen.add(after)
    assert len(seen) == len(ENGINE_LIBRARIES) + 1
    upgrade({})  # back to what is installed: the same version as before
    assert version_of(settings) == before


@pytest.mark.slow
def test_an_upgrade_makes_stored_models_stale_until_re_described(
    database_url: str, upgrade: Upgrade
) -> None:
    settings = make_settings(database_url)

    def describe(content: bytes, filename: str) -> dict[str, Any]:
        # The fake engine stamps the version the real one would: the current one.
        return {**fake_describe(content, filename), "descriptor_version": current_version(settings)}

    engine = make_engine(database_url)
    sessions = make_session_factory(engine)
    with started_clients(database_url) as make:
        client = make(handler=describe)
        model = upload(client, PARTS / "20mm-xyz-cube.stl").json()
        assert wait_for_status(client, model["id"])["status"] == "ready"
        before = client.get("/v1/stats").json()
        old = before["current_descriptor_version"]
        assert before["by_descriptor_version"] == {old: 1}
        assert before["engine_libraries"] == dict(engine_library_versions())
        assert enqueue_models(sessions, from_version=None, everything=False, current=old) == []

        upgrade({"scipy": "999.0"})
        after = client.get("/v1/stats").json()
        new = after["current_descriptor_version"]
        assert new != old and after["engine_libraries"]["scipy"] == "999.0"
        assert after["by_descriptor_version"] == {old: 1}  # from another version now
        # shapesearch redescribe's default choice picks it, and the worker moves it.
        jobs = enqueue_models(sessions, from_version=None, everything=False,
                              current=current_version(settings))
        assert len(jobs) == 1
        deadline = time.monotonic() + 30
        while client.get("/v1/stats").json()["by_descriptor_version"] != {new: 1}:
            assert time.monotonic() < deadline, client.get("/v1/stats").json()
            time.sleep(0.05)
    engine.dispose()
