"""/docs and /redoc load every asset from this service: nothing from a CDN.

The real-browser proof (network to anything but 127.0.0.1 blocked) is in test_browser.py;
here every URL the pages reference is checked to be local and served.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.api.main import create_app
from tests.conftest import make_settings


@pytest.fixture
def client(tmp_path: Path) -> Iterator[TestClient]:
    settings = make_settings(f"sqlite:///{tmp_path / 'shapesearch.db'}")
    with TestClient(create_app(settings)) as client:
        yield client


def referenced_urls(html: str) -> list[str]:
    """Every src/href attribute and every quoted URL of the page's inline script."""
    attributes = re.findall(r"""(?:src|href)=["']([^"']+)["']""", html)
    script_urls = re.findall(r"""url: ?["']([^"']+)["']""", html)
    return attributes + script_urls


@pytest.mark.parametrize("page", ["/docs", "/redoc"])
def test_docs_pages_reference_only_local_assets(client: TestClient, page: str) -> None:
    response = client.get(page)
    assert response.status_code == 200
    urls = referenced_urls(response.text)
    assert any(url.endswith(".js") for url in urls), urls
    for url in urls:
        assert url.startswith("/") and not url.startswith("//"), f"{page} loads {url}"
        asset = client.get(url)
        assert asset.status_code == 200, url
        assert len(asset.content) > 100, url
    assert "fonts.googleapis" not in response.text
    assert "cdn." not in response.text


def test_swagger_bundle_is_the_real_library(client: TestClient) -> None:
    html = client.get("/docs").text
    script = next(u for u in referenced_urls(html) if u.endswith("swagger-ui-bundle.js"))
    body = client.get(script).text
    assert len(body) > 500_000 and "SwaggerUIBundle" in body
