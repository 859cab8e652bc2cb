"""``shapesearch serve``: the API under uvicorn, with the embedded worker unless --no-worker."""

from __future__ import annotations

import ipaddress
import sys

import uvicorn

from app.api.main import create_app
from app.db.migrate import upgrade
from app.db.session import make_engine, make_session_factory
from app.keys import keys_exist
from app.logs import configure_logging
from app.settings import Settings

__all__ = ["is_loopback", "serve"]


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
    uvicorn.run(
        create_app(settings, embedded_worker=embedded_worker),
        host=host,
        port=port,
        log_config=None,
        access_log=False,
    )
    return 0
