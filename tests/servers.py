"""``shapesearch serve`` in a subprocess, for tests that need a real server: its own peak
memory (VmHWM in /proc) and real concurrency."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx

__all__ = ["peak_memory_bytes", "running_server"]


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


@contextmanager
def running_server(
    data_dir: Path, *, worker: bool = False, **settings: object
) -> Iterator[tuple[str, int]]:
    """(base URL, pid) of ``shapesearch serve`` on a new SQLite database, with ``settings``
    as SHAPESEARCH_* variables; ``--no-worker`` unless ``worker``."""
    port = _free_port()
    env = {
        **os.environ,
        "SHAPESEARCH_DATABASE_URL": f"sqlite:///{data_dir / 'db.sqlite'}",
        "SHAPESEARCH_PORT": str(port),
        **{f"SHAPESEARCH_{name.upper()}": str(value) for name, value in settings.items()},
    }
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", *([] if worker else ["--no-worker"])],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    base = f"http://127.0.0.1:{port}"
    try:
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
    finally:
        process.terminate()
        process.wait(timeout=60)
