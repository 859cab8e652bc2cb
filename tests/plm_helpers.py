"""Helpers of the PLM tests: apps with a controllable fake describer, shapes as bytes."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import trimesh
from fastapi.testclient import TestClient

from app.api.main import create_app
from tests.conftest import fake_describe, make_settings

ClientFactory = Callable[..., TestClient]
Request = tuple[str, dict[str, str], bytes]  # path, headers, body


def box_stl(x: float, y: float = 1.0, z: float = 1.0) -> bytes:
    """A box of extents (x, y, z) as binary STL: a small valid part, unique per size."""
    return bytes(trimesh.creation.box(extents=(x, y, z)).export(file_type="stl"))


class GatedDescriber:
    """``fake_describe`` that holds every file containing ``marker`` until ``release``."""

    def __init__(self, marker: bytes) -> None:
        self.marker = marker
        self.gate = threading.Event()
        self.entered = threading.Event()

    def __call__(self, content: bytes, filename: str) -> dict[str, Any]:
        if self.marker in content:
            self.entered.set()
            self.gate.wait(60)
        return fake_describe(content, filename)

    def release(self) -> None:
        self.gate.set()


@contextmanager
def started_clients(database_url: str) -> Iterator[ClientFactory]:
    """``make(handler=fake_describe, **settings)``: started apps, closed at the end."""
    clients: list[TestClient] = []

    def make(handler: Any = fake_describe, embedded_worker: bool = True,
             **overrides: Any) -> TestClient:
        settings = make_settings(database_url, **{"webhook_allow_private": True, **overrides})
        app = create_app(settings, embedded_worker=embedded_worker, job_handler=handler)
        client = TestClient(app, raise_server_exceptions=False)
        client.__enter__()
        clients.append(client)
        return client

    try:
        yield make
    finally:
        for client in reversed(clients):
            client.__exit__(None, None, None)


class Receiver:
    """A webhook receiver on 127.0.0.1: answers with ``statuses`` in turn (then 200) and
    records every request's headers and body; with ``hold``, each request is recorded, then
    answered only once ``hold`` is set (an endpoint that hangs until the test lets it go)."""

    def __init__(
        self,
        statuses: list[int] | None = None,
        redirect_to: str | None = None,
        hold: threading.Event | None = None,
    ) -> None:
        self.statuses = list(statuses or [])
        self.redirect_to = redirect_to
        self.requests: list[Request] = []
        self.lock = threading.Lock()
        receiver = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self) -> None:  # noqa: N802 (http.server's naming)
                body = self.rfile.read(int(self.headers.get("content-length", 0)))
                with receiver.lock:
                    receiver.requests.append((self.path, dict(self.headers.items()), body))
                    status = receiver.statuses.pop(0) if receiver.statuses else 200
                if hold is not None:
                    hold.wait(60)
                if receiver.redirect_to is not None and self.path != receiver.redirect_to:
                    status = 307
                self.send_response(status)
                if status == 307:
                    self.send_header("Location", receiver.redirect_to or "/")
                self.send_header("content-length", "0")
                self.end_headers()

            def log_message(self, *args: Any) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.server.server_address[1]}/hook"

    def __enter__(self) -> Receiver:
        self.thread.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.server.shutdown()
        self.server.server_close()

    def wait_for(self, count: int, timeout: float = 30.0) -> list[Request]:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self.lock:
                if len(self.requests) >= count:
                    return list(self.requests)
            time.sleep(0.02)
        raise AssertionError(f"{len(self.requests)} requests, expected {count}")
