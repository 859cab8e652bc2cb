"""Reader of Point Cloud Library ``.pcd`` files: ``DATA ascii``, ``binary`` and
``binary_compressed``.

A PCD file is a text header (``FIELDS x y z ...``, ``SIZE``, ``TYPE``, ``COUNT``, ``WIDTH``,
``HEIGHT``, ``POINTS``, ``DATA``) followed by the points: text lines, packed little-endian
records, or (``binary_compressed``) two uint32 sizes, compressed and uncompressed, then one
LZF block that expands to the fields one after the other (all x, then all y, ...). Only the
``x``, ``y``, ``z`` fields are kept.

Every size the header declares is checked before anything is allocated: the point count
against ``MAX_PARSED_POINTS``, the uncompressed size against the records it must hold,
against ``MAX_RECORD_BYTES`` and against what LZF can expand the compressed bytes to; the
decompression itself is bounded by that declared size.
"""

from __future__ import annotations

import io
import struct
from dataclasses import dataclass

import lzf
import numpy as np

from core.errors import InvalidShapeError
from core.io._validate import MAX_PARSED_POINTS, MAX_RECORD_BYTES

__all__ = ["check_pcd_header", "read_pcd"]

# A PCD header is ten short lines or so; stop looking for DATA well before reading a big file.
_MAX_HEADER_BYTES = 65536
_TYPE_CODES = {"F": "f", "I": "i", "U": "u"}
_MODES = ("ascii", "binary", "binary_compressed")
# binary_compressed: compressed size, uncompressed size, both uint32 little-endian.
_SIZES = struct.Struct("<II")
# LZF's longest back-reference copies 264 bytes from a 3-byte token: no LZF block expands
# more than 88-fold, so a header that says otherwise lies.
_LZF_MAX_RATIO = 88


@dataclass(frozen=True)
class _Field:
    """One FIELDS entry: its name, the numpy type of one value, and values per point."""

    name: str
    dtype: np.dtype
    count: int


@dataclass(frozen=True)
class _Layout:
    """A PCD file checked up to its data: the fields, the point count, the data mode, and
    the bytes after the header."""

    fields: list[_Field]
    n: int
    mode: str
    body: bytes

    @property
    def record_bytes(self) -> int:
        return sum(field.dtype.itemsize * field.count for field in self.fields)


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
        "its header has no 'DATA' line; the header must end with 'DATA ascii', 'DATA binary' "
        "or 'DATA binary_compressed'"
    )


def _fields(header: dict[str, list[str]]) -> list[_Field]:
    """The FIELDS with their SIZE, TYPE and COUNT, checked for consistency."""
    names = header.get("FIELDS")
    if not names:
        raise _refuse("its header has no 'FIELDS' line")
    if not {"x", "y", "z"} <= set(names):
        raise _refuse(f"it has fields {' '.join(names)} but needs x, y and z")
    sizes = header.get("SIZE", ["4"] * len(names))
    types = [t.upper() for t in header.get("TYPE", ["F"] * len(names))]
    counts = [int(c) for c in header.get("COUNT", ["1"] * len(names))]
    if not len(names) == len(sizes) == len(types) == len(counts):
        raise _refuse("its FIELDS, SIZE, TYPE and COUNT lines have different lengths")
    fields = []
    for name, size, kind, count in zip(names, sizes, types, counts, strict=True):
        if kind not in _TYPE_CODES or size not in ("1", "2", "4", "8"):
            raise _refuse(f"field {name} has unsupported TYPE {kind} / SIZE {size}")
        if count < 1:
            raise _refuse(f"field {name} has COUNT {count}")
        fields.append(_Field(name, np.dtype(f"<{_TYPE_CODES[kind]}{size}"), count))
    return fields


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


def _check_binary(layout: _Layout) -> None:
    needed = layout.n * layout.record_bytes
    if len(layout.body) < needed:
        raise _refuse(
            f"it declares {layout.n:,} points of {layout.record_bytes} bytes but only "
            f"{len(layout.body):,} bytes follow the header (truncated upload?)"
        )


def _compressed_sizes(layout: _Layout) -> tuple[int, int]:
    """The (compressed, uncompressed) sizes of a binary_compressed block, checked against
    the records they must hold, the limit and the bytes present; nothing is expanded."""
    if len(layout.body) < _SIZES.size:
        raise _refuse("its compressed data has no size header (truncated upload?)")
    compressed, uncompressed = _SIZES.unpack_from(layout.body)
    needed = layout.n * layout.record_bytes
    if uncompressed != needed:
        raise _refuse(
            f"its compressed data declares {uncompressed:,} bytes uncompressed, but "
            f"{layout.n:,} points of {layout.record_bytes} bytes take {needed:,}"
        )
    if uncompressed > MAX_RECORD_BYTES:
        raise InvalidShapeError(
            "too_large",
            f"the PCD file's points take {uncompressed:,} bytes uncompressed, more than the "
            f"{MAX_RECORD_BYTES:,} accepted: drop unused fields or thin the point cloud",
        )
    if _SIZES.size + compressed > len(layout.body):
        raise _refuse(
            f"its compressed data declares {compressed:,} bytes but only "
            f"{len(layout.body) - _SIZES.size:,} follow (truncated upload?)"
        )
    if uncompressed > _LZF_MAX_RATIO * compressed:
        raise _refuse(
            f"its {compressed:,} compressed bytes are declared to expand to {uncompressed:,}, "
            f"more than LZF's {_LZF_MAX_RATIO}-fold at most"
        )
    return compressed, uncompressed


def _layout(data: bytes) -> _Layout:
    """Parse and check the header, and the sizes its data mode declares."""
    header, offset = _parse_header(data)
    fields = _fields(header)
    n = _point_count(header)
    mode = (header["DATA"] or [""])[0].lower()
    if mode not in _MODES:
        raise _refuse(f"unknown 'DATA {mode}'; PCD data is ascii, binary or binary_compressed")
    layout = _Layout(fields, n, mode, data[offset:])
    if n and mode == "binary":
        _check_binary(layout)
    elif n and mode == "binary_compressed":
        _compressed_sizes(layout)
    return layout


def check_pcd_header(data: bytes) -> None:
    """Refuse a PCD file whose header declares more than it holds or than we accept.

    Parameters
    ----------
    data : bytes
        The whole file; only the header and the sizes after it are read.

    Raises
    ------
    InvalidShapeError
        ``unparsable`` (bad header, truncated data, impossible sizes) or ``too_large``.
    """
    _layout(data)


def _read_ascii(layout: _Layout) -> np.ndarray:
    # Column of each field's first value once multi-valued fields are spread out.
    counts = [field.count for field in layout.fields]
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    names = [field.name for field in layout.fields]
    columns = tuple(int(starts[names.index(axis)]) for axis in "xyz")
    text = layout.body.decode("ascii", errors="replace")
    points = np.loadtxt(io.StringIO(text), usecols=columns, ndmin=2, max_rows=layout.n)
    if len(points) < layout.n:
        raise _refuse(f"it declares {layout.n:,} points but holds {len(points):,}")
    return points


def _record_dtype(fields: list[_Field]) -> np.dtype:
    """Packed little-endian record of one point (``DATA binary``)."""
    entries: list[tuple[str, np.dtype, tuple[int, ...]]] = []
    for index, field in enumerate(fields):
        # Padding fields are often all called "_": numpy needs unique names.
        taken = [entry[0] for entry in entries]
        unique = field.name in ("x", "y", "z") and field.name not in taken
        name = field.name if unique else f"f{index}"
        entries.append((name, field.dtype, (field.count,) if field.count > 1 else ()))
    return np.dtype(entries)


def _read_binary(layout: _Layout) -> np.ndarray:
    n = layout.n
    records = np.frombuffer(layout.body, dtype=_record_dtype(layout.fields), count=n)
    # A multi-valued x field would be odd; its first value is the coordinate.
    return np.stack(
        [records[axis].reshape(n, -1)[:, 0].astype(np.float64) for axis in "xyz"], axis=1
    )


def _read_compressed(layout: _Layout) -> np.ndarray:
    """Expand the LZF block (at most the declared, checked size) and take x, y, z from it."""
    compressed, uncompressed = _compressed_sizes(layout)
    block = layout.body[_SIZES.size : _SIZES.size + compressed]
    try:
        # lzf.decompress never writes past its second argument: None if it would.
        expanded = lzf.decompress(block, uncompressed)
    except ValueError as error:
        raise _refuse("its LZF-compressed data is corrupt") from error
    if expanded is None or len(expanded) != uncompressed:
        raise _refuse(
            f"its compressed data expands to {'more' if expanded is None else len(expanded)}"
            f" bytes instead of the {uncompressed:,} declared"
        )
    # The fields follow one another: field i is n * count_i values starting after the others.
    columns: dict[str, np.ndarray] = {}
    offset = 0
    for field in layout.fields:
        if field.name in ("x", "y", "z") and field.name not in columns:
            values = np.frombuffer(
                expanded, dtype=field.dtype, count=layout.n * field.count, offset=offset
            )
            columns[field.name] = values.reshape(layout.n, field.count)[:, 0]
        offset += layout.n * field.count * field.dtype.itemsize
    return np.stack([columns[axis].astype(np.float64) for axis in "xyz"], axis=1)


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
        ``unparsable`` (bad header, truncated or corrupt data, impossible sizes),
        ``too_large``.
    """
    layout = _layout(data)
    if layout.n == 0:
        return np.zeros((0, 3))
    if layout.mode == "ascii":
        return _read_ascii(layout)
    if layout.mode == "binary":
        return _read_binary(layout)
    return _read_compressed(layout)
