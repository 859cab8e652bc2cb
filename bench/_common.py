"""Helpers the benchmarks share: the repository's paths, a ``shapesearch`` process on a free
port, and peak memory."""

from __future__ import annotations

import os
import resource
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx

__all__ = ["PARTS", "REPO", "free_port", "healthy", "peak_rss_mb", "shapesearch", "wait_until"]

REPO = Path(__file__).resolve().parents[1]
#: The test fixtures' parts (tests/fixtures/parts).
PARTS = REPO / "tests" / "fixtures" / "parts"
#: The ``shapesearch`` command of this venv.
COMMAND = str(Path(sys.executable).parent / "shapesearch")


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def wait_until(check: Callable[[], bool], timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while not check():
        if time.monotonic() > deadline:
            raise TimeoutError("the service did not get there in time")
        time.sleep(0.2)


def healthy(base: str) -> bool:
    try:
        return httpx.get(f"{base}/healthz").status_code == 200
    except httpx.HTTPError:
        return False


@contextmanager
def shapesearch(*commands: list[str], env: dict[str, str] | None = None) -> Iterator[str]:
    """``shapesearch`` processes (default: ``serve``) on a free port with a fresh data
    directory unless ``env`` or the environment names one, their output discarded; yields
    the base URL once ``/healthz`` answers, and stops them after."""
    port = free_port()
    merged = {**os.environ, "SHAPESEARCH_PORT": str(port), **(env or {})}
    merged.setdefault("SHAPESEARCH_DATA_DIR", tempfile.mkdtemp())
    quiet = subprocess.DEVNULL
    processes = [subprocess.Popen([COMMAND, *arguments], env=merged, stdout=quiet, stderr=quiet)
                 for arguments in commands or [["serve"]]]
    base = f"http://127.0.0.1:{port}"
    try:
        wait_until(lambda: healthy(base), 60)
        yield base
    finally:
        for process in processes:
            process.terminate()
            process.wait(30)


def peak_rss_mb() -> float:
    """This process's peak resident set size so far, in MB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
