"""Reading an uploaded shape file and refusing, cheaply and at once, what can never work.

413 above the size limit (counted while hashing), 415 for a format we do not read, 413/422
when the header promises more than the file holds or than we accept (every size), 422 for
content that fails a quick parse (empty, unparsable, non-finite, too few points), 503 when
this process has no memory left for that parse (the file is not blamed). The quick
parse samples only ``upload_check_points`` points; the full description runs later.

The quick parse is a courtesy (an early 422 instead of a failed job), not the verdict, so it
is bounded: a file that could hurt this process is parsed in a sandboxed child, at most
``upload_check_max_concurrent`` at once per process, and waiting for a slot and checking
together take at most ``upload_check_timeout_seconds``. Past that the upload is accepted
unchecked (logged, and counted in ``shapesearch_uploads_unchecked_total``): the worker's
describe, with the full limits, decides. A file that hangs its reader then holds one worker
for ``describe_timeout_seconds`` instead of an API thread and a child each per upload.

The upload arrives as Starlette's spooled temporary file (on disk beyond 1 MiB); it is
hashed in chunks from there and read into memory once, never copied twice.
"""

from __future__ import annotations

import hashlib
import logging
import threading
import time
from dataclasses import dataclass
from typing import Annotated, Any, BinaryIO

from fastapi import Form

from app.api.limits import too_large_problem
from app.api.problems import Problem
from app.ingest.describing import quick_check
from app.ingest.sandbox import SandboxTimeout, sandbox_of
from app.observability.metrics import UNCHECKED_UPLOADS
from app.problems import reason_kind
from app.settings import Settings
from app.storage import storage_full
from core.errors import InvalidShapeError
from core.io import (
    CRASHING_FORMATS,
    EXPANDING_FORMATS,
    SUPPORTED_FORMATS,
    check_header,
    detect_format,
)

__all__ = [
    "UPLOAD_FILE_HELP", "BackgroundField", "CheckedUpload", "UploadReader",
    "invalid_shape_problem", "out_of_memory_problem",
]

#: The OpenAPI description of every shape upload field.
UPLOAD_FILE_HELP = (
    "Mesh, point cloud, scanner or CAD file; its name's extension tells the format: "
    + ", ".join(SUPPORTED_FORMATS)
    + " (stp and igs too)."
)

#: The form field that marks an upload as part of a bulk load (``app.jobs.turns``).
BackgroundField = Annotated[
    bool,
    Form(description="true for an upload that is part of a bulk load (`shapesearch import` "
         "sends it): its job takes turns with the tenant's other uploads instead of "
         "holding them up, as a catalogue's re-describe does. Scheduling only: the model "
         "and its descriptor are the same."),
]

log = logging.getLogger("shapesearch.api")

_CHUNK = 1024 * 1024
# Above this size only the format is checked at upload: parsing a huge mesh in the request
# would hold an API thread for seconds; the worker refuses it later with a reason.
FULL_CHECK_MAX_BYTES = 16 * 1024 * 1024
# Files up to this size (of formats whose geometry grows with the file, read by parsers a
# malformed file cannot crash) hold too little geometry to hurt, and are parsed in-process;
# anything else is parsed in the sandbox, which costs a process start.
IN_PROCESS_CHECK_MAX_BYTES = 256 * 1024


@dataclass(frozen=True)
class CheckedUpload:
    content: bytes
    filename: str
    format: str
    sha256: str


def invalid_shape_problem(error: InvalidShapeError) -> Problem:
    """The HTTP refusal of an ``InvalidShapeError``, by its reason (``app.problems``)."""
    return Problem(reason_kind(error.reason), error.message, reason=error.reason)


def _hash_limited(stream: BinaryIO, max_bytes: int) -> str:
    """sha256 of the stream, read in chunks; 413 as soon as it passes ``max_bytes``."""
    digest = hashlib.sha256()
    size = 0
    while chunk := stream.read(_CHUNK):
        size += len(chunk)
        if size > max_bytes:
            raise too_large_problem(max_bytes)
        digest.update(chunk)
    stream.seek(0)
    return digest.hexdigest()


#: Retry-After of the 503 when this process has no memory for a quick check, in seconds.
MEMORY_RETRY_AFTER_SECONDS = 5


def out_of_memory_problem() -> Problem:
    """The 503 of a quick check that found this process out of memory (not the file's
    fault: retry later)."""
    return Problem(
        "busy",
        "The service is short of memory right now; the file was not checked. Retry in "
        f"{MEMORY_RETRY_AFTER_SECONDS} s.",
        headers={"Retry-After": str(MEMORY_RETRY_AFTER_SECONDS)},
    )


def _safe_in_process(content: bytes, fmt: str) -> bool:
    """Whether parsing ``content`` in this process is safe: a small file of a format whose
    geometry grows with its size (not GLB, whose scene can instance a mesh many times, nor
    LAZ or E57, whose points can compress to almost nothing: ``EXPANDING_FORMATS``) and whose
    reader a malformed file cannot crash (not STEP, IGES or LAZ: ``CRASHING_FORMATS``)."""
    return (len(content) <= IN_PROCESS_CHECK_MAX_BYTES
            and fmt not in EXPANDING_FORMATS and fmt not in CRASHING_FORMATS)


def base_name(filename: str | None) -> str:
    """The file's own name, without any directory part a client sent (``../../x.stl``,
    ``C:\\parts\\x.stl``): what is stored, shown and served as the file's name."""
    name = (filename or "").replace("\\", "/").rsplit("/", 1)[-1].strip()
    return name if name not in ("", ".", "..") else "upload"


class UploadReader:
    """Reads one app's uploads: the bounded read, the header checks and the quick parse,
    holding the slots of its sandboxed checks (one reader per app, built at start).

    Parameters
    ----------
    settings : Settings
        The limits: ``max_upload_bytes``, ``upload_check_points``, ``min_points``,
        ``upload_check_timeout_seconds``, ``upload_check_max_concurrent`` and the sandbox's.
    """

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self._slots = threading.BoundedSemaphore(settings.upload_check_max_concurrent)

    def read(
        self, stream: BinaryIO, filename: str | None, *, parse: bool = True
    ) -> CheckedUpload:
        """Read the file (bounded) and run the quick checks; raises ``Problem`` on refusal.

        ``parse=False`` skips the quick parse, for a caller that describes the file at once
        anyway (``POST /v1/search``: the describe in the sandbox parses it fully).
        """
        settings = self.settings
        sha256 = _hash_limited(stream, settings.max_upload_bytes)
        content = stream.read()
        name = base_name(filename)
        try:
            if not content or content.isspace():
                raise InvalidShapeError("empty_file", "file is empty: upload a point cloud or mesh")
            fmt = detect_format(name, content[:4096])
            check_header(content, fmt)
            if parse and len(content) <= FULL_CHECK_MAX_BYTES:
                check = (
                    content, name, settings.upload_check_points, settings.min_points,
                    settings.sample_seed,
                )
                if _safe_in_process(content, fmt):
                    quick_check(*check)
                else:  # parsed in a child: a bomb cannot grow this process, nor a crash end it
                    self._check_in_sandbox(name, check)
        except InvalidShapeError as error:
            raise invalid_shape_problem(error) from error
        except MemoryError as error:
            # Only a small file of a format that cannot expand is parsed in this process (the
            # sandbox's limit makes any other 413 too-large): here the service is short of
            # memory right now, and the file is not at fault.
            log.error("quick check of %r: this process is out of memory", name)
            raise out_of_memory_problem() from error
        except Exception as error:  # a parser bug must not become a 500 for the client
            if storage_full(error):  # the machine's fault, not the file's: 507
                raise
            log.exception("quick check of %r failed", name)
            raise invalid_shape_problem(
                InvalidShapeError("unparsable", f"the file could not be read: {error}")
            ) from error
        return CheckedUpload(content=content, filename=name, format=fmt, sha256=sha256)

    def _check_in_sandbox(self, name: str, check: tuple[Any, ...]) -> None:
        """``quick_check(*check)`` of the file ``name`` in a sandboxed child within one of the
        slots, waiting for the slot and checking within ``upload_check_timeout_seconds``
        together; when that runs out the file is let through unchecked (the worker decides)."""
        budget = self.settings.upload_check_timeout_seconds
        started = time.monotonic()
        if not self._slots.acquire(timeout=budget):
            self._unchecked(name, "busy")
            return
        try:
            remaining = budget - (time.monotonic() - started)
            if remaining <= 0:
                self._unchecked(name, "busy")
                return
            sandbox_of(self.settings, remaining).run(quick_check, *check)
        except SandboxTimeout:
            self._unchecked(name, "timeout")
        finally:
            self._slots.release()

    def _unchecked(self, name: str, reason: str) -> None:
        seconds = self.settings.upload_check_timeout_seconds
        what = "no check slot came free" if reason == "busy" else "the check did not finish"
        log.warning("upload %r accepted unchecked: %s within %g s "
                    "(SHAPESEARCH_UPLOAD_CHECK_TIMEOUT_SECONDS)", name, what, seconds)
        UNCHECKED_UPLOADS.labels(reason=reason).inc()
