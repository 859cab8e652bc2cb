"""The web viewer: a single page at ``/`` with its scripts under ``/viewer/``.

Plain ES modules and a small WebGL point renderer of our own, shipped as package data: no
CDN, no build step, nothing fetched from outside the service. The page reads the public
/v1 API with the caller's key in an ``Authorization`` header.
"""

from __future__ import annotations

from pathlib import Path

from fastapi import FastAPI
from fastapi.responses import FileResponse
from fastapi.staticfiles import StaticFiles
from starlette.datastructures import MutableHeaders
from starlette.types import ASGIApp, Message, Receive, Scope, Send

__all__ = ["STATIC_DIR", "LocalOnlyPages", "install_viewer"]

STATIC_DIR = Path(__file__).parent / "static"

# The browser may load nothing from elsewhere: ReDoc, for one, asks a CDN for its logo.
# (Swagger UI's page and ReDoc's bundle need inline scripts and styles.)
CONTENT_SECURITY_POLICY = (
    "default-src 'self'; script-src 'self' 'unsafe-inline'; style-src 'self' 'unsafe-inline'; "
    "img-src 'self' data: blob:; font-src 'self' data:; worker-src 'self' blob:; "
    "connect-src 'self'"
)
HTML_PAGES = ("/", "/docs", "/redoc")


class LocalOnlyPages:
    """ASGI middleware: the HTML pages get a Content-Security-Policy that keeps every
    request they make on this service."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope["path"] not in HTML_PAGES:
            await self.app(scope, receive, send)
            return

        async def send_with_policy(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = MutableHeaders(scope=message)
                headers["Content-Security-Policy"] = CONTENT_SECURITY_POLICY
            await send(message)

        await self.app(scope, receive, send_with_policy)


def install_viewer(app: FastAPI) -> None:
    """Serve the viewer page at ``/`` and its assets at ``/viewer/``; keep the HTML pages
    (the viewer and the API docs) from loading anything from elsewhere."""
    app.add_middleware(LocalOnlyPages)

    @app.get("/", include_in_schema=False)
    def viewer_page() -> FileResponse:
        return FileResponse(STATIC_DIR / "index.html", headers={"Cache-Control": "no-cache"})

    app.mount("/viewer", StaticFiles(directory=STATIC_DIR), name="viewer")
