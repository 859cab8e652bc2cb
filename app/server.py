"""``shapesearch serve``: the API under uvicorn, with the embedded worker unless --no-worker."""

from __future__ import annotations

import ipaddress
import os
import sys
from typing import Any

import uvicorn
from fastapi import FastAPI

from app.api.main import create_app
from app.db.migrate import upgrade
from app.db.session import make_engine, make_session_factory
from app.keys import keys_exist
from app.logs import configure_logging
from app.settings import Settings

__all__ = ["app_in_process", "is_loopback", "serve"]

# How ``serve`` tells the API processes it spawns whether to embed a worker: they build
# their app in a fresh interpreter (``app_in_process``) and inherit the environment.
_EMBEDDED_WORKER = "_SHAPESEARCH_EMBEDDED_WORKER"


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def serve(host: str | None = None, port: int | None = None, embedded_worker: bool = True) -> int:
    settings = Settings()
    host = host or settings.host
    port = port or settings.port
    configure_logging()

    engine = make_engine(settings.resolved_database_url)
    upgrade(engine)
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

    # log_config=None keeps the JSON logging configured above (uvicorn's default config
    # would replace it and add a second, plain access line per request on stdout).
    options: dict[str, Any] = {"host": host, "port": port, "log_config": None, "access_log": False}
    if settings.api_processes == 1:
        uvicorn.run(create_app(settings, embedded_worker=embedded_worker), **options)
        return 0
    os.environ[_EMBEDDED_WORKER] = "1" if embedded_worker else ""
    uvicorn.run(
        f"{__name__}:app_in_process", factory=True, workers=settings.api_processes, **options
    )
    return 0


def app_in_process() -> FastAPI:
    """The app of one of ``api_processes`` API processes (a uvicorn worker): the embedded
    worker's threads, when there is one, are shared out so the processes run as many
    describes together as one process would."""
    configure_logging()
    settings = Settings()
    threads = -(-settings.worker_count // settings.api_processes)  # 0 stays 0
    return create_app(
        settings.model_copy(update={"workers": threads}),
        embedded_worker=bool(os.environ.get(_EMBEDDED_WORKER)),
    )
