"""Refuse oversized request bodies before they are read.

Pure ASGI middleware: a declared ``Content-Length`` above the limit is answered 413 at
once; otherwise the bytes are counted as the app receives them and the 413 is raised as
soon as the count passes the limit, so a chunked or lying client cannot stream an
unbounded body either. (Starlette spools multipart files to disk beyond 1 MiB, so the
body is never held in memory whole.)
"""

from __future__ import annotations

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.api.problems import Problem, problem_response

__all__ = ["BodySizeLimit"]


def _too_large(limit: int) -> str:
    return f"The request body is larger than the limit of {limit} bytes."


class BodySizeLimit:
    def __init__(self, app: ASGIApp, max_body_bytes: int) -> None:
        self.app = app
        self.max_body_bytes = max_body_bytes

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit = self.max_body_bytes
        for name, value in scope["headers"]:
            if name == b"content-length" and value.isdigit() and int(value) > limit:
                response = problem_response(413, _too_large(limit), headers={"Connection": "close"})
                await response(scope, receive, send)
                return

        received = 0

        async def counted_receive() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    raise Problem(413, _too_large(limit))
            return message

        await self.app(scope, counted_receive, send)
