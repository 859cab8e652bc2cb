"""Hostile files against a real server process: each is refused with the right status and
reason, and the serving process's peak memory stays bounded.

The server runs as ``shapesearch serve`` in a subprocess so that its peak resident memory
(VmHWM in /proc) is its own and not the test runner's.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from tests.hostile_files import HOSTILE_FILES
from tests.servers import peak_memory_bytes, running_server

PEAK_MEMORY_BOUND = 500 * 1024 * 1024

pytestmark = pytest.mark.skipif(
    not Path("/proc/self/status").exists(), reason="peak memory is read from /proc"
)


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, int]]:
    """(base URL, pid) of a server on an empty SQLite database."""
    with running_server(tmp_path_factory.mktemp("hostile")) as running:
        yield running


@pytest.mark.slow
@pytest.mark.parametrize("route", ["/v1/models", "/v1/search"])
@pytest.mark.parametrize("name", list(HOSTILE_FILES))
def test_a_hostile_file_is_refused_without_growing_the_server(
    server: tuple[str, int], name: str, route: str
) -> None:
    base, pid = server
    filename, make, status, reason = HOSTILE_FILES[name]
    response = httpx.post(
        base + route, files={"file": (filename, make(), "application/octet-stream")}, timeout=120
    )
    assert response.status_code == status, response.text
    body = response.json()
    assert body["reason"] == reason
    assert body["type"] == f"urn:shapesearch:problem:{reason.replace('_', '-')}"
    assert peak_memory_bytes(pid) < PEAK_MEMORY_BOUND
