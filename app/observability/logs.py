"""Logs: one JSON object per line and event (python-json-logger) for a log collector, or
one readable line per event for a person at a terminal (``SHAPESEARCH_LOG_FORMAT``).

A log line is handed to a bounded queue and written by a thread of its own, so a slow or
stuck sink (a pipe nobody reads, a full disk, a collector that stalls) never holds the event
loop or a request: with the queue full (``QUEUED_LINES``), lines are dropped and counted,
and the next line written says how many were lost. Formatting happens in the writing
thread, from the record as it was logged (its message merged with its arguments at once).

Every line carries the request id of the HTTP request it belongs to (``X-Request-ID``: taken
from the client when it is a sane token, else made up; always returned) and, in workers, the
job id. Both travel in context variables, so no call site passes them along. Keys never
reach a log: no header is logged, and routes log tenants, never credentials.

    configure_logging()     the process's log lines on stderr (serve, worker): JSON, or
                            text when asked or, by default, when stderr is a terminal;
                            written by a thread of their own (``background``)
    flush_logs()            wait until every line logged so far is written
    RequestId               ASGI middleware: request id in, out, on every line, one access line
    job_context(job_id)     context manager: the job id on every line of the block
    Outage                  a background loop's outage (its database away or full): logged
                            when it starts, once a minute while it lasts, when it ends
"""

from __future__ import annotations

import atexit
import itertools
import logging
import os
import queue
import re
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from logging.handlers import QueueHandler
from typing import Literal, TextIO

from pythonjsonlogger.json import JsonFormatter
from starlette.datastructures import MutableHeaders
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.storage import storage_full

__all__ = [
    "QUEUED_LINES", "LogFormat", "Outage", "RequestId", "configure_logging", "first_line",
    "flush_logs", "job_context", "request_id",
]

#: Log lines waiting for the writing thread at most; beyond, lines are dropped and counted.
QUEUED_LINES = 10_000

#: ``SHAPESEARCH_LOG_FORMAT``: JSON lines, readable text, or text on a terminal only.
LogFormat = Literal["auto", "json", "text"]

request_id: ContextVar[str | None] = ContextVar("request_id", default=None)
job_id: ContextVar[str | None] = ContextVar("job_id", default=None)

access_log = logging.getLogger("shapesearch.access")

_SANE_ID = re.compile(r"^[A-Za-z0-9._:-]{1,128}$")

# Made-up request ids: a random prefix per process and a counter, 32 hex digits like a
# UUID's, unique without a trip to the kernel's random source on every request.
_ID_PREFIX = os.urandom(8).hex()
_id_counter = itertools.count()


def _new_request_id() -> str:
    return f"{_ID_PREFIX}{next(_id_counter):016x}"


class _ContextFilter(logging.Filter):
    """Adds request_id and job_id (when set) to every record."""

    def filter(self, record: logging.LogRecord) -> bool:
        for name, variable in (("request_id", request_id), ("job_id", job_id)):
            value = variable.get()
            if value is not None and not hasattr(record, name):
                setattr(record, name, value)
        return True


class _Handoff(QueueHandler):
    """Hands records to the writing thread without blocking: the context ids are added
    here (the filter runs in the logging thread, where the context variables are), the
    message merged with its arguments, and a record that finds the queue full is dropped
    and counted."""

    def __init__(self, lines: queue.Queue[logging.LogRecord | None]) -> None:
        super().__init__(lines)
        self.lines = lines
        self.dropped = 0
        self._lock = threading.Lock()

    def prepare(self, record: logging.LogRecord) -> logging.LogRecord:
        record.msg, record.args = record.getMessage(), None
        return record

    def enqueue(self, record: logging.LogRecord) -> None:
        with self._lock:
            if self.dropped and not self.lines.full():
                lost, self.dropped = self.dropped, 0
                self.lines.put_nowait(logging.makeLogRecord({
                    "name": "shapesearch.logs", "levelno": logging.WARNING,
                    "levelname": "WARNING", "msg": f"{lost} log lines dropped: the log "
                    "sink was slower than the lines came"}))
            try:
                self.lines.put_nowait(record)
            except queue.Full:
                self.dropped += 1


class _Writer:
    """The thread that writes the queued lines through ``handler`` (a daemon: a sink stuck
    for good does not keep the process alive)."""

    def __init__(self, lines: queue.Queue[logging.LogRecord | None],
                 handler: logging.Handler) -> None:
        self.lines = lines
        self.handler = handler
        self.thread = threading.Thread(target=self._run, name="log-writer", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while True:
            record = self.lines.get()
            try:
                if record is None:
                    return
                self.handler.handle(record)
            finally:
                self.lines.task_done()

    def stop(self, timeout: float = 5.0) -> None:
        """Write what is queued (waiting at most ``timeout`` seconds), then end."""
        try:
            self.lines.put(None, timeout=timeout)
        except queue.Full:
            return
        self.thread.join(timeout)


_writer: _Writer | None = None


def flush_logs() -> None:
    """Wait until every line logged so far is written (no-op when lines are written in the
    logging thread)."""
    if _writer is not None:
        _writer.lines.join()


def _stop_writer() -> None:
    global _writer
    if _writer is not None:
        _writer.stop()
        _writer = None


atexit.register(_stop_writer)


def _write_directly_after_fork() -> None:
    """A forked child has no writer thread: it writes its lines itself."""
    global _writer
    if _writer is not None:
        handler, _writer = _writer.handler, None
        handler.addFilter(_ContextFilter())
        logging.getLogger().handlers[:] = [handler]


os.register_at_fork(after_in_child=_write_directly_after_fork)


def configure_logging(
    level: int = logging.INFO, stream: TextIO | None = None, log_format: LogFormat = "auto",
    background: bool = True,
) -> None:
    """Log lines on ``stream`` (default stderr) for every logger of the process (uvicorn's
    included): JSON, or text with ``log_format`` "text" or, with "auto", when ``stream``
    is a terminal; written by a thread of their own unless ``background`` is False."""
    global _writer
    _stop_writer()
    handler = logging.StreamHandler(stream)
    formatter: logging.Formatter
    if _wants_text(log_format, handler.stream):
        formatter = TextFormatter()
    else:
        formatter = JsonFormatter(
            "{asctime}{levelname}{name}{message}",
            style="{",
            rename_fields={"asctime": "time", "levelname": "level", "name": "logger"},
        )
    handler.setFormatter(formatter)
    root = logging.getLogger()
    if background:
        lines: queue.Queue[logging.LogRecord | None] = queue.Queue(QUEUED_LINES)
        handoff = _Handoff(lines)
        handoff.addFilter(_ContextFilter())
        _writer = _Writer(lines, handler)
        root.handlers[:] = [handoff]
    else:
        handler.addFilter(_ContextFilter())
        root.handlers[:] = [handler]
    root.setLevel(level)
    for name in ("uvicorn", "uvicorn.error", "uvicorn.access"):
        logging.getLogger(name).handlers[:] = []
        logging.getLogger(name).propagate = True
    logging.getLogger("uvicorn.access").disabled = True  # RequestId writes the access line


def _wants_text(log_format: LogFormat, stream: TextIO) -> bool:
    if log_format != "auto":
        return log_format == "text"
    try:
        return stream.isatty()
    except (AttributeError, ValueError, OSError):  # no such method, or closed
        return False


# The attributes every record has; the others are the ``extra`` fields of its call, shown
# in text but for uvicorn's copy of its message with terminal colours.
_RECORD_ATTRIBUTES = frozenset(
    vars(logging.LogRecord("", 0, "", 0, "", None, None))
) | {"message", "asctime", "taskName", "color_message"}
_IDS = ("request_id", "job_id")


class TextFormatter(logging.Formatter):
    """One line per record for a person (as uvicorn's are): time, level, logger and
    message, then the record's extra fields and its request and job id as ``name=value``
    (an access line: ``request method=GET route=/v1/models status=200 duration_ms=3.1
    request_id=...``); a traceback on the lines below."""

    def format(self, record: logging.LogRecord) -> str:
        fields = [
            (name, value) for name, value in vars(record).items()
            if name not in _RECORD_ATTRIBUTES and name not in _IDS
        ]
        fields += [(name, getattr(record, name)) for name in _IDS if hasattr(record, name)]
        line = (f"{self.formatTime(record)} {record.levelname:<8} {record.name}: "
                f"{record.getMessage()}")
        line += "".join(f" {name}={_shown(value)}" for name, value in fields)
        if record.exc_info and not record.exc_text:
            record.exc_text = self.formatException(record.exc_info)
        if record.exc_text:
            line += "\n" + record.exc_text
        if record.stack_info:
            line += "\n" + self.formatStack(record.stack_info)
        return line


def _shown(value: object) -> str:
    """A field's value as text, quoted when it is empty or holds a space."""
    text = str(value)
    return repr(text) if not text or any(c.isspace() for c in text) else text


@contextmanager
def job_context(job: object) -> Iterator[None]:
    token = job_id.set(str(job))
    try:
        yield
    finally:
        job_id.reset(token)


class RequestId:
    """ASGI middleware: the request id (client's ``X-Request-ID`` if sane, else new) in the
    context while the request runs, in the response header, and in one access line."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        given = dict(scope["headers"]).get(b"x-request-id", b"").decode("latin-1")
        rid = given if _SANE_ID.match(given) else _new_request_id()
        token = request_id.set(rid)
        started = time.perf_counter()
        status = 500

        async def send_with_id(message: Message) -> None:
            nonlocal status
            if message["type"] == "http.response.start":
                status = int(message["status"])
                MutableHeaders(scope=message)["X-Request-ID"] = rid
            await send(message)

        try:
            await self.app(scope, receive, send_with_id)
        finally:
            route = getattr(scope.get("route"), "path", None) or "unmatched"
            access_log.info(
                "request",
                extra={
                    "method": scope["method"],
                    "route": route,
                    "status": status,
                    "duration_ms": round((time.perf_counter() - started) * 1000, 1),
                },
            )
            request_id.reset(token)


def first_line(error: BaseException) -> str:
    """What went wrong, without the SQL and parameters SQLAlchemy appends (a descriptor's
    bytes among them)."""
    return (str(error).splitlines() or [type(error).__name__])[0][:300]


class Outage:
    """The log of one background loop's outage (the worker's queue, webhook deliveries,
    the index sync): the first error in full, a line every ``interval`` seconds while it
    lasts, one when it ends; not a traceback per poll (a PostgreSQL restart of 30 s was 30
    of them per loop and process).

    Parameters
    ----------
    logger : logging.Logger
        Where the loop logs.
    what : str
        What is unavailable, for the messages ("worker w1: queue").
    interval : float
        Seconds between the lines of a lasting outage.
    clock : () -> float
        Seconds, monotonic.
    """

    def __init__(
        self, logger: logging.Logger, what: str, interval: float = 60.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.logger = logger
        self.what = what
        self.interval = interval
        self.clock = clock
        self.started: float | None = None
        self.logged = 0.0

    def report(self, error: Exception) -> None:
        """The loop failed with ``error``."""
        now = self.clock()
        if self.started is None:
            self.started = self.logged = now
            if storage_full(error):  # the condition, not the code: no traceback
                self.logger.error("%s: storage full, nothing can be stored until space is "
                                  "freed: %s", self.what, first_line(error))
            else:
                self.logger.error("%s unavailable", self.what, exc_info=error)
        elif now - self.logged >= self.interval:
            self.logged = now
            self.logger.warning("%s unavailable for %.0f s: %s", self.what, now - self.started,
                                first_line(error))

    def end(self) -> None:
        """The loop succeeded: an outage, if any, is over."""
        if self.started is not None:
            self.logger.info("%s available again after %.0f s", self.what,
                             self.clock() - self.started)
            self.started = None
