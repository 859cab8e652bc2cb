"""Hostile files against a real server process: each is refused with the right status and
reason, and the serving process's peak memory stays bounded.

The server runs as ``shapesearch serve`` in a subprocess so that its peak resident memory
(VmHWM in /proc) is its own and not the test runner's.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from hostile_files import HOSTILE_FILES

PEAK_MEMORY_BOUND = 500 * 1024 * 1024

pytestmark = pytest.mark.skipif(
    not Path("/proc/self/status").exists(), reason="peak memory is read from /proc"
)


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def peak_memory_bytes(pid: int) -> int:
    """VmHWM: the process's peak resident set size."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
    raise AssertionError("no VmHWM")


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, int]]:
    """(base URL, pid) of ``shapesearch serve --no-worker`` on an empty SQLite database."""
    port = _free_port()
    data = tmp_path_factory.mktemp("hostile")
    env = {
        **os.environ,
        "SHAPESEARCH_DATABASE_URL": f"sqlite:///{data / 'db.sqlite'}",
        "SHAPESEARCH_PORT": str(port),
    }
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", "--no-worker"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    base = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 120
    while True:
        try:
            if httpx.get(f"{base}/healthz", timeout=2).status_code == 200:
                break
        except httpx.TransportError:
            pass
        assert process.poll() is None, "the server exited"
        assert time.monotonic() < deadline, "the server did not start"
        time.sleep(0.2)
    yield base, process.pid
    process.terminate()
    process.wait(timeout=60)


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
