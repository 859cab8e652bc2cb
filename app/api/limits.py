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

__all__ = ["BodySizeLimit", "too_large_problem"]


def too_large_problem(max_upload_bytes: int) -> Problem:
    """The 413 of an upload above ``SHAPESEARCH_MAX_UPLOAD_BYTES``, naming that limit."""
    return Problem(
        "too-large",
        f"The upload is larger than the limit of {max_upload_bytes} bytes "
        "(SHAPESEARCH_MAX_UPLOAD_BYTES).",
        limit=max_upload_bytes,
    )


class BodySizeLimit:
    """``max_upload_bytes`` for the file plus ``overhead_bytes`` for the form around it."""

    def __init__(self, app: ASGIApp, max_upload_bytes: int, overhead_bytes: int = 0) -> None:
        self.app = app
        self.max_upload_bytes = max_upload_bytes
        self.max_body_bytes = max_upload_bytes + overhead_bytes

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit = self.max_body_bytes
        for name, value in scope["headers"]:
            if name == b"content-length" and value.isdigit() and int(value) > limit:
                problem = too_large_problem(self.max_upload_bytes)
                response = problem_response(problem.record, headers={"Connection": "close"})
                await response(scope, receive, send)
                return

        received = 0

        async def counted_receive() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    raise too_large_problem(self.max_upload_bytes)
            return message

        await self.app(scope, counted_receive, send)
