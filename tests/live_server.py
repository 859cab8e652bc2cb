"""``live_server(tmp_path)``: a real ``shapesearch serve`` in a subprocess, on a random port.

For the tests that talk to the service as a user would (the README's curl session, the
browser): the installed command line, uvicorn, the embedded worker and the real engine with
the small settings of the test suite, on a SQLite database in a temporary directory.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from tests.conftest import FAST_QUEUE, SMALL_ENGINE

__all__ = ["free_port", "live_server"]


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _server_env(data_dir: Path, extra: dict[str, str]) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("SHAPESEARCH_")}
    env["SHAPESEARCH_DATA_DIR"] = str(data_dir)
    for name, value in {**SMALL_ENGINE, **FAST_QUEUE}.items():
        env[f"SHAPESEARCH_{name.upper()}"] = str(value)
    env.update(extra)
    return env


@contextmanager
def live_server(
    data_dir: Path, extra_env: dict[str, str] | None = None, timeout: float = 60.0
) -> Iterator[str]:
    """Run ``shapesearch serve`` until the block ends; yields its base URL."""
    port = free_port()
    log = (data_dir / "server.log").open("wb")
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", "--port", str(port)],
        cwd=data_dir,
        env=_server_env(data_dir, extra_env or {}),
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + timeout
        while True:
            if process.poll() is not None:
                raise AssertionError(f"serve exited: {(data_dir / 'server.log').read_text()}")
            try:
                with urllib.request.urlopen(f"{url}/healthz", timeout=2) as response:
                    if response.status == 200:
                        break
            except OSError:
                pass
            if time.monotonic() > deadline:
                raise AssertionError("serve did not answer /healthz in time")
            time.sleep(0.2)
        yield url
    finally:
        process.terminate()
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        log.close()
