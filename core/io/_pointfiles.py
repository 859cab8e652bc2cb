"""Readers of the point-only formats that need no library: text columns and ``.npy``.

Text (``.xyz``, ``.txt``, ``.csv``, ``.pts``)
    One point per line, ``x y z`` first, separated by spaces, tabs, commas or semicolons;
    further columns (normals, colours, intensity) are ignored. Blank lines and comments
    (``#``, ``//``, ``%``) may appear anywhere; lines before the first point that are not three
    numbers (a ``.pts`` point count, a CSV header ``x,y,z``) are skipped as a header.
``.npy``
    A numeric ``(n, k)`` array with ``k >= 3`` (the first three columns are x, y, z), or a
    structured array with fields ``x``, ``y``, ``z``. Never unpickled.

Readers return the points as parsed, ``(n, 3)`` float64, possibly empty or non-finite: the
checks belong to ``validate_points``.
"""

from __future__ import annotations

import io
import re

import numpy as np

from core.errors import InvalidShapeError
from core.io._validate import MAX_PARSED_POINTS

__all__ = ["read_npy", "read_text_points"]

_COMMENTS = ("#", "//", "%")
# Commas, semicolons and tabs all separate columns; mapping them to spaces lets one parser
# read every variant, including files that mix them.
_SEPARATORS = str.maketrans({",": " ", ";": " ", "\t": " "})
# Lines before the first point that may be a header; more than this is not a point file.
_MAX_HEADER_LINES = 100
_NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|[-+]?(nan|inf|infinity)$", re.I)


def _is_comment(line: str) -> bool:
    stripped = line.strip()
    return not stripped or stripped.startswith(_COMMENTS)


def _is_point_row(line: str) -> bool:
    """True when the line starts with three numbers (after separator normalisation)."""
    tokens = line.split()
    return len(tokens) >= 3 and all(_NUMBER.match(t) for t in tokens[:3])


def _first_point_line(lines: list[str]) -> int | None:
    """Index of the first line holding a point, None when there is none in the header zone."""
    header = 0
    for index, line in enumerate(lines):
        if _is_comment(line):
            continue
        if _is_point_row(line):
            return index
        header += 1
        if header > _MAX_HEADER_LINES:
            return None
    return None


def _bad_line(lines: list[str], start: int) -> tuple[int, str]:
    """1-based number and text of the first line after ``start`` that is not a point row."""
    for index in range(start, len(lines)):
        line = lines[index]
        if not _is_comment(line) and not _is_point_row(line):
            return index + 1, line.strip()[:60]
    return start + 1, ""


def read_text_points(data: bytes, fmt: str) -> np.ndarray:
    """Parse whitespace/comma separated ``x y z [...]`` lines.

    Parameters
    ----------
    data : bytes
        The whole file.
    fmt : str
        ``"xyz"``, ``"txt"``, ``"csv"`` or ``"pts"``, used in messages.

    Returns
    -------
    (n, 3) float64
        The first three columns of every point line; ``n == 0`` when the file holds only
        blank lines and comments.

    Raises
    ------
    InvalidShapeError
        ``unparsable`` (binary content, no point lines, a malformed line after the first
        point), ``too_large``.
    """
    if b"\x00" in data:
        raise InvalidShapeError(
            "unparsable",
            f"this .{fmt} file contains binary data, but .{fmt} point files are text with one "
            "'x y z' point per line: check the file or its extension",
        )
    lines = data.decode("utf-8-sig", errors="replace").translate(_SEPARATORS).splitlines()
    if len(lines) > MAX_PARSED_POINTS + _MAX_HEADER_LINES:
        raise InvalidShapeError(
            "too_large",
            f"the file has {len(lines):,} lines, more than the {MAX_PARSED_POINTS:,} points "
            "accepted: thin the point cloud before uploading it",
        )
    start = _first_point_line(lines)
    if start is None:
        if all(_is_comment(line) for line in lines):
            return np.zeros((0, 3))
        raise InvalidShapeError(
            "unparsable",
            f"no line of this .{fmt} file starts with three numbers 'x y z': upload one point "
            "per line, coordinates separated by spaces or commas",
        )
    try:
        # numpy's C parser: fast, and tolerant of ragged extra columns beyond the third.
        return np.loadtxt(
            io.StringIO("\n".join(lines[start:])),
            comments=list(_COMMENTS),
            usecols=(0, 1, 2),
            ndmin=2,
            dtype=np.float64,
        )
    except ValueError as exc:
        number, text = _bad_line(lines, start)
        raise InvalidShapeError(
            "unparsable",
            f"line {number} of this .{fmt} file is not a point ('{text}'): every line after "
            "the header must start with three numbers x y z",
        ) from exc


def _npy_header(stream: io.BytesIO) -> tuple[tuple[int, ...], np.dtype]:
    """Shape and dtype from a ``.npy`` header, without reading the data."""
    version = np.lib.format.read_magic(stream)
    if version == (1, 0):
        shape, _, dtype = np.lib.format.read_array_header_1_0(stream)
    else:
        shape, _, dtype = np.lib.format.read_array_header_2_0(stream)
    return shape, dtype


def _npy_refusal(detail: str) -> InvalidShapeError:
    return InvalidShapeError(
        "unparsable",
        f"{detail}: save the points as a numeric (n, 3) array, e.g. numpy.save('part.npy', "
        "points.astype('float64'))",
    )


def read_npy(data: bytes) -> np.ndarray:
    """Read a ``.npy`` array of points without ever unpickling.

    Parameters
    ----------
    data : bytes
        The whole file.

    Returns
    -------
    (n, 3) float64

    Raises
    ------
    InvalidShapeError
        ``unparsable`` (not a numeric (n, >=3) or x/y/z structured array), ``too_large``.
    """
    stream = io.BytesIO(data)
    try:
        shape, dtype = _npy_header(stream)
    except ValueError as exc:
        raise _npy_refusal(f"this is not a readable .npy file ({exc})") from exc
    if dtype.hasobject:
        raise _npy_refusal("the .npy file holds Python objects, which are never loaded")
    if shape and shape[0] > MAX_PARSED_POINTS:
        raise InvalidShapeError(
            "too_large",
            f"the array has {shape[0]:,} points, more than the {MAX_PARSED_POINTS:,} accepted: "
            "thin the point cloud before uploading it",
        )
    stream.seek(0)
    array = np.load(stream, allow_pickle=False)
    if array.dtype.names is not None:
        if not {"x", "y", "z"} <= set(array.dtype.names) or array.ndim != 1:
            raise _npy_refusal(f"the structured array has fields {array.dtype.names}")
        array = np.stack([array[name] for name in "xyz"], axis=1)
    if array.dtype.kind not in "fiu":
        raise _npy_refusal(f"the array has dtype {array.dtype}, not numbers")
    if array.ndim != 2 or array.shape[1] < 3:
        raise _npy_refusal(f"the array has shape {array.shape}, not (n, 3)")
    return np.asarray(array[:, :3], dtype=np.float64)
