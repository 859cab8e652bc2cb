"""A micro-cache of the hot read answers: catalogue pages and similar-model lists.

A similar or list request costs ~10x what the framework itself costs (a database round trip,
a FAISS search, a pydantic answer), while PLM clients and viewers repeat the same requests.
This ASGI middleware keeps the bytes of successful ``GET /v1/models`` and
``GET /v1/models/{id}/similar`` answers for ``response_cache_seconds`` (default 1 s) and
serves repeats from memory, on the event loop, before routing and authentication.

Freshness:

- any write through this process (a request that is not GET, HEAD or OPTIONS) drops every
  entry once it is answered, so a client reads its own writes at once;
- any change the search index applies (this process's worker finishing a job, the change
  feed bringing another process's models) drops every entry;
- everything else (another process's upload still queued, a status that moved on in another
  process, a key revoked elsewhere) shows within ``response_cache_seconds``, which is kept at
  or below ``auth_cache_seconds`` so that a revoked key still stops within that time.

The key is the path, the query string and the ``Authorization`` header: a tenant only ever
sees answers given to its own key. Memory is bounded by ``max_bytes`` (least recently used
entries go first); an answer larger than a tenth of it is not kept.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from starlette.types import ASGIApp, Message, Receive, Scope, Send

__all__ = ["ResponseCache", "cacheable"]

_READS = frozenset({"GET", "HEAD", "OPTIONS"})


def cacheable(scope: Scope) -> bool:
    """Whether ``scope`` asks for an answer this cache keeps: the model list or a
    similar-model list (not one model: its status is polled while a job runs)."""
    if scope["method"] != "GET":
        return False
    path: str = scope["path"]
    return path == "/v1/models" or (path.startswith("/v1/models/") and path.endswith("/similar"))


@dataclass(frozen=True)
class _Entry:
    start: Message
    body: bytes
    route: Any  # the matched route, so that logs and metrics label a hit like a miss
    expires: float
    generation: tuple[int, int]


class ResponseCache:
    """ASGI middleware; see the module docstring.

    Parameters
    ----------
    app : ASGIApp
        The application it wraps.
    seconds : float
        How long an answer is served from memory; 0 turns the cache off.
    index_changes : callable returning int
        A counter that moves whenever the search index applies a change.
    max_bytes : int
        Budget for the kept answers' bodies.
    """

    def __init__(
        self,
        app: ASGIApp,
        *,
        seconds: float,
        index_changes: Callable[[], int],
        max_bytes: int = 32 * 1024 * 1024,
    ) -> None:
        self.app = app
        self.seconds = seconds
        self.index_changes = index_changes
        self.max_bytes = max_bytes
        self._entries: OrderedDict[tuple[str, bytes, bytes], _Entry] = OrderedDict()
        self._bytes = 0
        self._writes = 0  # writes answered by this process

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or self.seconds <= 0:
            await self.app(scope, receive, send)
            return
        if scope["method"] not in _READS:
            try:
                await self.app(scope, receive, send)
            finally:
                self._writes += 1
                self.clear()
            return
        if not cacheable(scope):
            await self.app(scope, receive, send)
            return
        key = (scope["path"], scope["query_string"], _authorization(scope))
        generation = (self._writes, self.index_changes())
        entry = self._entries.get(key)
        if entry is not None and entry.generation == generation and (
            entry.expires > time.monotonic()
        ):
            self._entries.move_to_end(key)
            scope["route"] = entry.route
            await send(_copy(entry.start))
            await send({"type": "http.response.body", "body": entry.body})
            return
        await self._answer_and_keep(scope, receive, send, key, generation)

    async def _answer_and_keep(
        self,
        scope: Scope,
        receive: Receive,
        send: Send,
        key: tuple[str, bytes, bytes],
        generation: tuple[int, int],
    ) -> None:
        start: Message | None = None
        chunks: list[bytes] = []

        async def send_and_collect(message: Message) -> None:
            nonlocal start
            if message["type"] == "http.response.start":
                start = _copy(message)  # before outer middleware add per-request headers
            elif message["type"] == "http.response.body":
                chunks.append(message.get("body", b""))
            await send(message)

        await self.app(scope, receive, send_and_collect)
        if start is None or start["status"] != 200:
            return
        body = b"".join(chunks)
        # A write answered meanwhile may have changed what this answer read: keep nothing.
        if generation != (self._writes, self.index_changes()):
            return
        if len(body) * 10 > self.max_bytes:
            return
        self._keep(key, _Entry(start, body, scope.get("route"),
                               time.monotonic() + self.seconds, generation))

    def _keep(self, key: tuple[str, bytes, bytes], entry: _Entry) -> None:
        old = self._entries.pop(key, None)
        if old is not None:
            self._bytes -= len(old.body)
        self._entries[key] = entry
        self._bytes += len(entry.body)
        while self._bytes > self.max_bytes:
            _, evicted = self._entries.popitem(last=False)
            self._bytes -= len(evicted.body)

    def clear(self) -> None:
        """Drop every kept answer."""
        self._entries.clear()
        self._bytes = 0


def _copy(start: Message) -> Message:
    """A response start whose header list is its own: outer middleware (request id, CORS)
    change the list they are sent in place."""
    return {**start, "headers": list(start.get("headers", []))}


def _authorization(scope: Scope) -> bytes:
    for name, value in scope["headers"]:
        if name == b"authorization":
            return bytes(value)
    return b""
