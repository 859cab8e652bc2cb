"""Helpers of the PLM tests: apps with a controllable fake describer, shapes as bytes."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import trimesh
from conftest import fake_describe, make_settings
from fastapi.testclient import TestClient

from app.api.main import create_app

ClientFactory = Callable[..., TestClient]


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
