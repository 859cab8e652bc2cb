"""Describing the scans of ``POST /v1/search``: bounded, sandboxed, and never twice.

Each search describes its upload synchronously, which costs seconds of CPU and hundreds of
MB in a sandboxed child process. ``SearchDescriber``

* admits at most ``search_max_concurrent`` searches at a time (``SearchAdmission``, before
  the upload is even read); one more is refused at once with 503 and ``Retry-After``.
  Queueing would only hold the client, a thread and the upload for longer while the machine
  is busy, and every admitted request is Python work competing for the GIL with the event
  loop that answers /healthz;
* answers an upload it has seen (same sha256, descriptor version and mode) without
  describing it: from a small LRU cache of recent results, or from a ready model of the
  same tenant uploaded with the same bytes (in scan mode, one that has a scan descriptor).

In scan mode the upload is described as a scan (``scan_descriptor``, ``app.search.similarity``).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session, undefer
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.api.problems import Problem, problem_response
from app.db.models import Model
from app.ingest.describing import SIZE_COLUMNS, described_columns
from app.ingest.sandbox import describe_sandbox
from app.observability.metrics import observe_description
from app.search.similarity import SearchMode
from app.settings import Settings
from core.descriptor import DescriptorSpec
from core.settings import EngineSettings

__all__ = ["SearchAdmission", "SearchDescriber"]

# The columns a search answer needs (model_columns of the description), per mode.
# ``sample`` (the scan's points, for ``explain``) may be None: a stored model described
# before it was kept still answers.
_COLUMNS: dict[str, tuple[str, ...]] = {
    "shape": ("n_points", "cutoff", "descriptor", "descriptor_version", *SIZE_COLUMNS,
              "sample"),
    "scan": ("n_points", "cutoff", "scan_descriptor", "descriptor_version", *SIZE_COLUMNS,
             "sample"),
}
_OPTIONAL = {*SIZE_COLUMNS, "sample"}


class SearchDescriber:
    """Per app: the admission limit and the cache of recent descriptions."""

    def __init__(self, settings: Settings, engine: EngineSettings) -> None:
        self.settings = settings
        self.engine = engine
        self.version = DescriptorSpec.from_settings(engine.descriptor).version(engine)
        self._slots = threading.BoundedSemaphore(settings.search_max_concurrent)
        self._cache: OrderedDict[str, dict[str, Any]] = OrderedDict()
        self._lock = threading.Lock()

    def describe(
        self,
        content: bytes,
        filename: str,
        sha256: str,
        session: Session,
        tenant: str,
        mode: SearchMode = "shape",
    ) -> dict[str, Any]:
        """The description columns of an upload (see ``app.ingest.describing.model_columns``) that
        a search in ``mode`` needs."""
        key = f"{mode}:{sha256}"
        known = self._cached(key) or self._stored(session, tenant, sha256, mode)
        if known is not None:
            return known
        columns = describe_sandbox(self.settings, len(content)).run(
            described_columns, content, filename, self.engine, None, mode == "scan"
        )
        observe_description(columns)
        self._remember(key, {name: columns.get(name) for name in _COLUMNS[mode]})
        return columns

    @contextmanager
    def admitted(self) -> Iterator[None]:
        """Hold one of the ``search_max_concurrent`` slots, or raise the 503 ``Problem``."""
        if not self._slots.acquire(blocking=False):
            seconds = self.settings.search_retry_after_seconds
            raise Problem(
                "busy",
                f"{self.settings.search_max_concurrent} searches are being described already "
                f"(SHAPESEARCH_SEARCH_MAX_CONCURRENT); retry in {seconds} s.",
                headers={"Retry-After": str(seconds)},
            )
        try:
            yield
        finally:
            self._slots.release()

    def _cached(self, key: str) -> dict[str, Any] | None:
        with self._lock:
            columns = self._cache.get(key)
            if columns is not None:
                self._cache.move_to_end(key)
            return columns

    def _remember(self, key: str, columns: dict[str, Any]) -> None:
        if self.settings.search_cache_size == 0:
            return
        with self._lock:
            self._cache[key] = columns
            self._cache.move_to_end(key)
            while len(self._cache) > self.settings.search_cache_size:
                self._cache.popitem(last=False)

    def _stored(
        self, session: Session, tenant: str, sha256: str, mode: SearchMode
    ) -> dict[str, Any] | None:
        """A ready model of this tenant made from the same bytes with the same descriptor.
        (Only this tenant's: another tenant's copy would reveal, by the speed of the answer,
        that it holds the file.)"""
        model = session.scalar(
            select(Model)
            .options(undefer(Model.descriptor), undefer(Model.scan_descriptor),
                     undefer(Model.sample))
            .where(
                Model.tenant == tenant,
                Model.file_sha256 == sha256,
                Model.status == "ready",
                Model.descriptor_version == self.version,
            )
            .limit(1)
        )
        columns = _COLUMNS[mode]
        # A model described before sizes were measured still answers (without a size).
        if model is None or any(
            getattr(model, name) is None for name in columns if name not in _OPTIONAL
        ):
            return None
        return {name: getattr(model, name) for name in columns}


class SearchAdmission:
    """ASGI middleware: ``POST /v1/search`` runs only inside one of the describer's slots;
    without a free slot it is answered 503 before its body is read."""

    def __init__(self, app: ASGIApp, describer: SearchDescriber) -> None:
        self.app = app
        self.describer = describer

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if not (
            scope["type"] == "http"
            and scope["method"] == "POST"
            and scope["path"].rstrip("/") == "/v1/search"
        ):
            await self.app(scope, receive, send)
            return
        try:
            slot = self.describer.admitted()
            slot.__enter__()
        except Problem as busy:
            response = problem_response(busy.record, headers=busy.headers)
            await response(scope, receive, send)
            return
        released = False

        def release() -> None:
            nonlocal released
            if not released:
                released = True
                slot.__exit__(None, None, None)

        async def send_releasing(message: Message) -> None:
            # Free the slot before the last byte leaves: a client that sends its next
            # search as soon as it has this answer must find the slot free.
            if message["type"] == "http.response.body" and not message.get("more_body"):
                release()
            await send(message)

        try:
            await self.app(scope, receive, send_releasing)
        finally:
            release()
