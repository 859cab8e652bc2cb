"""``shapesearch serve``: the API under uvicorn, with the embedded worker unless --no-worker;
``SHAPESEARCH_API_PROCESSES`` API processes on one port (``SO_REUSEPORT``), whose metrics
one scrape of ``/metrics`` sums (``app.observability.metrics``, multiprocess mode)."""

from __future__ import annotations

import logging
import multiprocessing
import multiprocessing.connection
import multiprocessing.process
import signal
import socket
import sys
from collections.abc import Sequence
from typing import Any

import uvicorn

from app.api.main import create_app
from app.auth.keys import keys_exist
from app.db.session import make_session_factory, migrated_engine
from app.net import is_loopback
from app.observability.logs import configure_logging
from app.observability.metrics import (
    process_exited,
    remove_stale_metrics,
    shared_metrics_directory,
)
from app.settings import Settings

__all__ = ["is_loopback", "serve"]

log = logging.getLogger(__name__)


def serve(host: str | None = None, port: int | None = None, embedded_worker: bool = True) -> int:
    settings = Settings()
    host = host or settings.host
    port = port or settings.port
    configure_logging(log_format=settings.log_format)

    engine = migrated_engine(settings.resolved_database_url)
    with make_session_factory(engine)() as session:
        open_service = not settings.require_api_keys and not keys_exist(session)
    engine.dispose()
    if open_service and not is_loopback(host):
        print(
            f"error: refusing to listen on {host}: no API key exists, so anyone who can reach "
            "that address could read and change every model. Create a key first "
            "(shapesearch keys create --tenant NAME) or set SHAPESEARCH_REQUIRE_API_KEYS=true, "
            "or listen on 127.0.0.1.",
            file=sys.stderr,
        )
        return 2

    if settings.api_processes == 1:
        remove_stale_metrics()  # only with a PROMETHEUS_MULTIPROC_DIR of the operator's
        uvicorn.run(
            create_app(settings, embedded_worker=embedded_worker), **_UVICORN, host=host, port=port
        )
        return 0
    return _serve_processes(settings.api_processes, host, port, embedded_worker)


# log_config=None keeps the logging configured by ``configure_logging`` (uvicorn's
# default config would replace it and add a second, plain access line per request).
_UVICORN: dict[str, Any] = {"log_config": None, "access_log": False}


def _serve_processes(count: int, host: str, port: int, embedded_worker: bool) -> int:
    """Run ``count`` API processes on one port until one of them stops.

    Each process listens on a socket of its own bound with ``SO_REUSEPORT``, so the kernel
    spreads new connections over them evenly. (With one shared listening socket, as
    uvicorn's ``--workers`` has it, the process that wakes first accepts a whole burst of
    connections: 16 clients connecting at once mostly ended up on one process, which then
    did nearly all the work.) When any process exits, the others are stopped and ``serve``
    exits non-zero, for the service manager to restart the whole service.
    """
    if not hasattr(socket, "SO_REUSEPORT"):
        print("error: SHAPESEARCH_API_PROCESSES > 1 needs SO_REUSEPORT (Linux)", file=sys.stderr)
        return 1
    try:
        # Bound, never listening: the port is ours (or this fails now, clearly), and a
        # socket that does not listen receives no connections.
        reserved = _port_socket(host, port)
    except OSError as error:
        print(f"error: cannot listen on {host}:{port}: {error.strerror}", file=sys.stderr)
        return 1
    # Set before the processes start, so that each writes its metrics there from its first
    # import of prometheus-client on.
    with reserved, shared_metrics_directory():
        spawn = multiprocessing.get_context("spawn")  # fresh interpreters: no forked threads
        processes = [
            spawn.Process(target=_api_process, args=(host, port, embedded_worker, count),
                          name=f"shapesearch-api-{i}")
            for i in range(count)
        ]  # fmt: skip
        asked_to_stop = False

        def on_signal(_signum: int, _frame: object) -> None:
            nonlocal asked_to_stop
            asked_to_stop = True
            _terminate(processes)

        for signum in (signal.SIGTERM, signal.SIGINT):
            signal.signal(signum, on_signal)
        for process in processes:
            process.start()
        multiprocessing.connection.wait([process.sentinel for process in processes])
        if not asked_to_stop:
            log.error("an API process exited; stopping the others")
            _terminate(processes)
        for process in processes:
            process.join()
            if process.pid is not None:
                process_exited(process.pid)
        return 0 if asked_to_stop else 1


def _terminate(processes: Sequence[multiprocessing.process.BaseProcess]) -> None:
    for process in processes:
        if process.is_alive():
            process.terminate()  # SIGTERM: uvicorn's graceful shutdown


def _port_socket(host: str, port: int) -> socket.socket:
    """A TCP socket bound to ``host:port`` that shares the port with the others bound so."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    bound = socket.socket(family, socket.SOCK_STREAM)
    bound.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    bound.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
    try:
        bound.bind((host, port))
    except OSError:
        bound.close()
        raise
    return bound


def _api_process(host: str, port: int, embedded_worker: bool, count: int) -> None:
    """One of ``count`` API processes: the embedded worker's threads, when there is one,
    are shared out so the processes run as many describes together as one process would."""
    settings = Settings()
    configure_logging(log_format=settings.log_format)
    threads = -(-settings.worker_count // count)  # 0 stays 0
    app = create_app(
        settings.model_copy(update={"workers": threads}), embedded_worker=embedded_worker
    )
    uvicorn.Server(uvicorn.Config(app, **_UVICORN)).run(sockets=[_port_socket(host, port)])
