"""Reader of Point Cloud Library ``.pcd`` files, ``DATA ascii`` and ``DATA binary``.

A PCD file is a text header (``FIELDS x y z ...``, ``SIZE``, ``TYPE``, ``COUNT``, ``WIDTH``,
``HEIGHT``, ``POINTS``, ``DATA``) followed by the points, either as text lines or as packed
little-endian records. Only the ``x``, ``y``, ``z`` fields are kept. ``binary_compressed``
(LZF-compressed columns) is refused with a message saying how to re-save the file.
"""

from __future__ import annotations

import io

import numpy as np

from core.errors import InvalidShapeError
from core.io._validate import MAX_PARSED_POINTS

__all__ = ["read_pcd"]

# A PCD header is ten short lines or so; stop looking for DATA well before reading a big file.
_MAX_HEADER_BYTES = 65536
_TYPE_CODES = {"F": "f", "I": "i", "U": "u"}
_RESAVE = (
    "re-save it with 'DATA ascii' or 'DATA binary' (for example with pcl_convert_pcd_ascii_binary)"
)


def _refuse(detail: str) -> InvalidShapeError:
    return InvalidShapeError("unparsable", f"this PCD file cannot be read: {detail}")


def _parse_header(data: bytes) -> tuple[dict[str, list[str]], int]:
    """Header entries by upper-case keyword, and the offset of the first data byte."""
    header: dict[str, list[str]] = {}
    offset = 0
    while offset < min(len(data), _MAX_HEADER_BYTES):
        end = data.find(b"\n", offset)
        end = len(data) if end < 0 else end
        line = data[offset:end].decode("ascii", errors="replace").strip()
        offset = end + 1
        if not line or line.startswith("#"):
            continue
        key, *values = line.split()
        header[key.upper()] = values
        if key.upper() == "DATA":
            return header, offset
    raise _refuse(
        "its header has no 'DATA' line; the header must end with 'DATA ascii' or 'DATA binary'"
    )


def _layout(header: dict[str, list[str]]) -> tuple[list[str], list[str], list[str], list[int]]:
    """Fields, sizes, types and counts, checked for consistency."""
    fields = header.get("FIELDS")
    if not fields:
        raise _refuse("its header has no 'FIELDS' line")
    if not {"x", "y", "z"} <= set(fields):
        raise _refuse(f"it has fields {' '.join(fields)} but needs x, y and z")
    sizes = header.get("SIZE", ["4"] * len(fields))
    types = [t.upper() for t in header.get("TYPE", ["F"] * len(fields))]
    counts = [int(c) for c in header.get("COUNT", ["1"] * len(fields))]
    if not len(fields) == len(sizes) == len(types) == len(counts):
        raise _refuse("its FIELDS, SIZE, TYPE and COUNT lines have different lengths")
    return fields, sizes, types, counts


def _point_count(header: dict[str, list[str]]) -> int:
    if "POINTS" in header:
        n = int(header["POINTS"][0])
    else:
        n = int(header.get("WIDTH", ["0"])[0]) * int(header.get("HEIGHT", ["1"])[0])
    if n < 0:
        raise _refuse(f"it declares {n} points")
    if n > MAX_PARSED_POINTS:
        raise InvalidShapeError(
            "too_large",
            f"the PCD file declares {n:,} points, more than the {MAX_PARSED_POINTS:,} accepted: "
            "thin the point cloud before uploading it",
        )
    return n


def _read_ascii(body: bytes, fields: list[str], counts: list[int], n: int) -> np.ndarray:
    # Column of each field's first value once multi-valued fields are spread out.
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    columns = tuple(int(starts[fields.index(axis)]) for axis in "xyz")
    text = body.decode("ascii", errors="replace")
    points = np.loadtxt(io.StringIO(text), usecols=columns, ndmin=2, max_rows=n)
    if len(points) < n:
        raise _refuse(f"it declares {n:,} points but holds {len(points):,}")
    return points


def _record_dtype(
    fields: list[str], sizes: list[str], types: list[str], counts: list[int]
) -> np.dtype:
    """Packed little-endian record of one point."""
    entries = []
    layout = zip(fields, sizes, types, counts, strict=True)
    for index, (name, size, kind, count) in enumerate(layout):
        if kind not in _TYPE_CODES or size not in ("1", "2", "4", "8"):
            raise _refuse(f"field {name} has unsupported TYPE {kind} / SIZE {size}")
        # Padding fields are often all called "_": numpy needs unique names.
        taken = [entry[0] for entry in entries]
        unique = name if name in ("x", "y", "z") and name not in taken else f"f{index}"
        shape = (count,) if count > 1 else ()
        entries.append((unique, f"<{_TYPE_CODES[kind]}{size}", shape))
    return np.dtype(entries)


def _read_binary(body: bytes, dtype: np.dtype, n: int) -> np.ndarray:
    if len(body) < n * dtype.itemsize:
        raise _refuse(
            f"it declares {n:,} points of {dtype.itemsize} bytes but only {len(body):,} bytes "
            "follow the header (truncated upload?)"
        )
    records = np.frombuffer(body, dtype=dtype, count=n)
    # A multi-valued x field would be odd; its first value is the coordinate.
    return np.stack(
        [records[axis].reshape(n, -1)[:, 0].astype(np.float64) for axis in "xyz"], axis=1
    )


def read_pcd(data: bytes) -> np.ndarray:
    """Read the x, y, z fields of a PCD file.

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
        ``unparsable`` (bad header, truncated data, ``binary_compressed``), ``too_large``.
    """
    header, offset = _parse_header(data)
    fields, sizes, types, counts = _layout(header)
    n = _point_count(header)
    mode = (header["DATA"] or [""])[0].lower()
    body = data[offset:]
    if n == 0:
        return np.zeros((0, 3))
    if mode == "ascii":
        return _read_ascii(body, fields, counts, n)
    if mode == "binary":
        return _read_binary(body, _record_dtype(fields, sizes, types, counts), n)
    if mode == "binary_compressed":
        raise _refuse(f"'DATA binary_compressed' is not supported: {_RESAVE}")
    raise _refuse(f"unknown 'DATA {mode}': {_RESAVE}")
