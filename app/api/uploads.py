"""Reading an uploaded shape file and refusing, cheaply and at once, what can never work.

413 above the size limit (counted while reading), 415 for a format we do not read, 422 for
content that fails a quick parse (empty, unparsable, non-finite, too few points). The quick
parse samples only ``upload_check_points`` points; the full description runs later.
"""

from __future__ import annotations

import hashlib
import logging
from dataclasses import dataclass
from typing import BinaryIO

from app.api.problems import Problem
from app.describing import problem_of_reason
from app.settings import Settings
from core.errors import InvalidShapeError
from core.io import detect_format, load_points

__all__ = ["CheckedUpload", "invalid_shape_problem", "read_checked_upload"]

log = logging.getLogger("shapesearch.api")

_CHUNK = 1024 * 1024
# Above this size only the format is checked at upload: parsing a huge mesh in the request
# would hold an API thread for seconds; the worker refuses it later with a reason.
FULL_CHECK_MAX_BYTES = 16 * 1024 * 1024


@dataclass(frozen=True)
class CheckedUpload:
    content: bytes
    filename: str
    format: str
    sha256: str


def invalid_shape_problem(error: InvalidShapeError) -> Problem:
    """The HTTP refusal of an ``InvalidShapeError``: 415, 413 or 422 by its reason."""
    status = {"unknown_format": 415, "cad_unavailable": 415, "too_large": 413}.get(
        error.reason, 422
    )
    record = problem_of_reason(error.reason, error.message)
    return Problem(
        status,
        record["detail"],
        slug=error.reason.replace("_", "-"),
        title=record["title"],
        reason=error.reason,
    )


def _read_limited(stream: BinaryIO, max_bytes: int) -> bytes:
    chunks: list[bytes] = []
    size = 0
    while chunk := stream.read(_CHUNK):
        size += len(chunk)
        if size > max_bytes:
            raise Problem(413, f"The file is larger than the limit of {max_bytes} bytes.")
        chunks.append(chunk)
    return b"".join(chunks)


def read_checked_upload(
    stream: BinaryIO, filename: str | None, settings: Settings
) -> CheckedUpload:
    """Read the file (bounded) and run the quick checks; raises ``Problem`` on refusal."""
    content = _read_limited(stream, settings.max_upload_bytes)
    name = filename or "upload"
    try:
        if not content or content.isspace():
            raise InvalidShapeError("empty_file", "file is empty: upload a point cloud or mesh")
        fmt = detect_format(name, content[:4096])
        if len(content) <= FULL_CHECK_MAX_BYTES:
            load_points(
                content,
                filename=name,
                max_points=settings.upload_check_points,
                min_points=settings.min_points,
                seed=settings.sample_seed,
            )
    except InvalidShapeError as error:
        raise invalid_shape_problem(error) from error
    except Exception as error:  # a parser bug must not become a 500 for the client
        log.exception("quick check of %r failed", name)
        raise invalid_shape_problem(
            InvalidShapeError("unparsable", f"the file could not be read: {error}")
        ) from error
    return CheckedUpload(
        content=content, filename=name, format=fmt, sha256=hashlib.sha256(content).hexdigest()
    )
