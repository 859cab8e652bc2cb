"""ASPRS LAS point clouds and their LAZ compression, through laspy and the lazrs backend.

A LAS file is a fixed header (point count, record size, offset of the first point), variable
length records (VLRs: projection, extra bytes, LAZ parameters), then the point records,
packed (``.las``) or arithmetic-coded in chunks (``.laz``). laspy reads all of it and applies
the header's scales and offsets, so the coordinates come out in the file's units.

laspy trusts the header: it loops over as many VLRs as the header declares (4 billion VLRs
past the end of a small file grow a process by gigabytes) and allocates the records of as
many points as declared. So ``check_las_header`` reads the few header fields that size
everything with ``struct`` first and refuses, before laspy sees the file:

* a point count above ``MAX_PARSED_POINTS`` (413 ``too_large``);
* VLRs that cannot fit between the header and the points, a point offset past the end;
* a ``.las`` whose packed records are not all there (truncated; laspy would return the
  points it found and say nothing);
* a ``.laz`` whose records would expand beyond ``MAX_RECORD_BYTES``;
* a ``.las`` holding LAZ-compressed points (they would escape the sandbox that ``.laz``
  uploads are parsed in, ``core.io.EXPANDING_FORMATS``).

LAZ is decoded by lazrs single-threaded (one describe per process); a LAZ that declares more
points than its chunks hold fails in lazrs and is refused as ``unparsable``. (Fixed-size LAZ
chunks carry no point count, so a count a few points too high decodes the chunk table after
the last point as points, as any LAZ reader would; a hundred too many already fail.)
"""

from __future__ import annotations

import io
import struct
from dataclasses import dataclass

import laspy
import numpy as np

from core.errors import InvalidShapeError
from core.io._validate import MAX_PARSED_POINTS, MAX_RECORD_BYTES

__all__ = ["check_las_header", "read_las"]

# The LAS 1.0-1.2 header: 227 bytes. The fields used here, at their fixed offsets:
_SIGNATURE = b"LASF"
_HEADER_1_0 = 227
_VERSION = struct.Struct("<BB")  # major, minor at 24
_SIZES = struct.Struct("<HIIBHI")  # header size, point offset, VLRs, format, record size, count
_SIZES_AT = 94
# LAS 1.4 adds a 64-bit point count at 247 (the 32-bit one may be 0); its header is 375 bytes.
_COUNT_1_4 = struct.Struct("<Q")
_COUNT_1_4_AT = 247
_HEADER_1_4 = 375
_VLR_HEADER = 54  # every VLR starts with a 54-byte header
# Point format byte: LAZ sets bit 7 (old LASzip files bit 6) on top of the format number.
_COMPRESSED_BITS = 0xC0


@dataclass(frozen=True)
class _Header:
    """The fields of a LAS header that size the file."""

    header_size: int
    point_offset: int
    vlrs: int
    compressed: bool
    record_size: int
    count: int


def _refuse(fmt: str, detail: str) -> InvalidShapeError:
    return InvalidShapeError(
        "unparsable",
        f"could not read this .{fmt} file ({detail}): check that it is a complete, valid "
        f".{fmt} file, or export the point cloud again",
    )


def _header(data: bytes, fmt: str) -> _Header:
    if len(data) < _HEADER_1_0 or not data.startswith(_SIGNATURE):
        raise _refuse(fmt, "it does not start with a LAS header ('LASF', 227 bytes)")
    major, minor = _VERSION.unpack_from(data, 24)
    if major != 1 or minor > 4:
        raise _refuse(fmt, f"LAS version {major}.{minor}; versions 1.0 to 1.4 are read")
    header_size, point_offset, vlrs, point_format, record_size, count = _SIZES.unpack_from(
        data, _SIZES_AT
    )
    if minor == 4:
        if header_size < _HEADER_1_4 or len(data) < _HEADER_1_4:
            raise _refuse(fmt, f"a LAS 1.4 header of {header_size} bytes, not {_HEADER_1_4}")
        # The 64-bit count is the one readers use; the 32-bit one is 0 or the same.
        count = _COUNT_1_4.unpack_from(data, _COUNT_1_4_AT)[0]
    return _Header(
        header_size=header_size,
        point_offset=point_offset,
        vlrs=vlrs,
        compressed=bool(point_format & _COMPRESSED_BITS),
        record_size=record_size,
        count=count,
    )


def _check_layout(header: _Header, size: int, fmt: str) -> None:
    """Header, VLRs and points must lie in the file, one after the other."""
    if not _HEADER_1_0 <= header.header_size <= header.point_offset:
        raise _refuse(
            fmt,
            f"its header size {header.header_size} and point offset {header.point_offset} "
            "are inconsistent",
        )
    if header.point_offset > size:
        raise _refuse(
            fmt,
            f"its points start at byte {header.point_offset:,} of a {size:,}-byte file "
            "(truncated upload?)",
        )
    room = header.point_offset - header.header_size
    if header.vlrs * _VLR_HEADER > room:
        raise _refuse(
            fmt,
            f"it declares {header.vlrs:,} variable length records, which cannot fit in the "
            f"{room:,} bytes before its points",
        )


def _check_points(header: _Header, size: int, fmt: str) -> None:
    """The declared points against the limits and, packed, against the bytes present."""
    if header.count > MAX_PARSED_POINTS:
        raise InvalidShapeError(
            "too_large",
            f"the .{fmt} file declares {header.count:,} points, more than the "
            f"{MAX_PARSED_POINTS:,} accepted: thin the point cloud before uploading it",
        )
    needed = header.count * header.record_size
    if not header.compressed:
        if header.point_offset + needed > size:
            raise _refuse(
                fmt,
                f"it declares {header.count:,} points of {header.record_size} bytes but only "
                f"{size - header.point_offset:,} bytes of points follow (truncated upload?)",
            )
        return
    if fmt == "las":
        raise _refuse(fmt, "its points are LAZ-compressed: upload it with the extension .laz")
    if needed > MAX_RECORD_BYTES:
        raise InvalidShapeError(
            "too_large",
            f"the .{fmt} file's {header.count:,} points of {header.record_size} bytes take "
            f"{needed:,} bytes once decompressed, more than the {MAX_RECORD_BYTES:,} "
            "accepted: drop extra dimensions or thin the point cloud",
        )


def check_las_header(data: bytes, fmt: str) -> None:
    """Refuse a LAS/LAZ file whose header declares more than it holds or than we accept.

    Parameters
    ----------
    data : bytes
        The whole file; only the header is read.
    fmt : str
        ``"las"`` or ``"laz"``, as detected (used in messages; a ``.las`` must be packed).

    Raises
    ------
    InvalidShapeError
        ``unparsable`` or ``too_large``.
    """
    header = _header(data, fmt)
    _check_layout(header, len(data), fmt)
    _check_points(header, len(data), fmt)


def read_las(data: bytes, fmt: str) -> np.ndarray:
    """Read the scaled x, y, z of every point of a LAS or LAZ file.

    Parameters
    ----------
    data : bytes
        The whole file.
    fmt : str
        ``"las"`` or ``"laz"``.

    Returns
    -------
    (n, 3) float64
        Coordinates in the file's units (its scales and offsets applied).

    Raises
    ------
    InvalidShapeError
        ``unparsable`` or ``too_large``; laspy's and lazrs's own errors on a corrupt file
        are turned into ``unparsable`` by the loader.
    """
    check_las_header(data, fmt)
    # read_evlrs=False: the extended VLRs at the end of a 1.4 file hold nothing we use.
    reader = laspy.LasReader(
        io.BytesIO(data), laz_backend=laspy.LazBackend.Lazrs, read_evlrs=False
    )
    with reader:
        points = reader.read_points(-1)
    declared = reader.header.point_count
    if len(points) != declared:
        raise _refuse(fmt, f"it declares {declared:,} points but holds {len(points):,}")
    return np.column_stack([np.asarray(points.x), np.asarray(points.y), np.asarray(points.z)])
