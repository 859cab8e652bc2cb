"""The viewer is served by the app from package data, whole, and ships in the wheel."""

from __future__ import annotations

import fnmatch
import re
import tomllib
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.api.main import create_app
from app.viewer import STATIC_DIR
from tests.conftest import make_settings

ROOT = Path(__file__).parents[2]


@pytest.fixture
def client(tmp_path: Path) -> Iterator[TestClient]:
    settings = make_settings(f"sqlite:///{tmp_path / 'shapesearch.db'}")
    with TestClient(create_app(settings)) as client:
        yield client


def test_every_viewer_file_is_package_data() -> None:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    patterns = config["tool"]["setuptools"]["package-data"]["app"]
    files = [p.relative_to(ROOT / "app").as_posix() for p in STATIC_DIR.rglob("*") if p.is_file()]
    assert {"viewer/static/index.html", "viewer/static/main.js"} <= set(files)
    for name in files:
        assert any(fnmatch.fnmatch(name, pattern) for pattern in patterns), name


def test_page_and_every_module_it_imports_are_served_locally(client: TestClient) -> None:
    page = client.get("/")
    assert page.status_code == 200 and "<main id=\"page\">" in page.text
    assert "default-src 'self'" in page.headers["content-security-policy"]
    pending = re.findall(r"""(?:src|href)="(/viewer/[^"]+)\"""", page.text)
    seen: set[str] = set()
    while pending:
        url = pending.pop()
        if url in seen:
            continue
        seen.add(url)
        asset = client.get(url)
        assert asset.status_code == 200, url
        if url.endswith(".js"):
            assert "javascript" in asset.headers["content-type"]
            assert "http://" not in asset.text and "https://" not in asset.text, url
            imports = re.findall(r"""from "\./([\w.]+)\"""", asset.text)
            pending += [f"/viewer/{name}" for name in imports]
    assert {"/viewer/main.js", "/viewer/pointview.js", "/viewer/api.js"} <= seen


def test_docs_pages_get_the_local_only_policy(client: TestClient) -> None:
    for path in ("/docs", "/redoc"):
        assert "img-src 'self'" in client.get(path).headers["content-security-policy"]
    assert "content-security-policy" not in client.get("/openapi.json").headers
