"""ASTM E57 scanner files, through pye57 (libE57Format).

An E57 file is a sequence of 1024-byte pages, each ending in a CRC-32C. A 48-byte header
gives the file's length and where its XML section lies; the XML describes every scan
(``data3D``: its pose, its point fields and the ``recordCount`` of its compressed vector of
points) and images; the points themselves are bit-packed, a field that never changes taking
no bits at all, so a small file can declare and really hold millions of points.

``check_e57_header`` reads the header and the XML's bytes with ``struct`` and refuses, before
libE57 parses anything: a truncated (or padded) file, an XML section outside the file, a
document type declaration (libE57's XML parser would expand its entities; E57 never needs
one), and record counts above ``MAX_PARSED_POINTS`` in total.

``read_e57`` then hands the file to pye57, which needs a path (a temporary file, removed
after the read), checks every scan's declared count again, and reads the points in chunks:
libE57 says how many records it really decoded, so a count larger than the data is refused
instead of returning the uninitialised rest of a buffer sized by the header. Invalid points
(``cartesianInvalidState`` or ``sphericalInvalidState`` not 0) are dropped, spherical
coordinates converted, and each scan placed by its pose, so several scans of one part merge
in the frame they were registered in.
"""

from __future__ import annotations

import re
import struct
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pye57
from pye57.utils import convert_spherical_to_cartesian

from core.errors import InvalidShapeError
from core.io._validate import MAX_PARSED_POINTS

__all__ = ["check_e57_header", "read_e57"]

# signature, major and minor version, file length, XML offset (physical), XML length
# (logical), page size.
_HEADER = struct.Struct("<8sIIQQQQ")
_SIGNATURE = b"ASTM-E57"
_PAGE = 1024
_PAGE_DATA = _PAGE - 4  # each page ends with its CRC-32C
_RECORD_COUNT = re.compile(rb"""\brecordCount\s*=\s*(["'])(.*?)\1""", re.S)
_DOCTYPE = re.compile(rb"<!\s*(DOCTYPE|ENTITY)", re.I)
_CARTESIAN = ("cartesianX", "cartesianY", "cartesianZ")
_SPHERICAL = ("sphericalRange", "sphericalAzimuth", "sphericalElevation")
# Records decoded per libE57 read call: the buffers stay small whatever the count.
_CHUNK = 65536


def _refuse(detail: str) -> InvalidShapeError:
    return InvalidShapeError(
        "unparsable",
        f"could not read this .e57 file ({detail}): check that it is a complete, valid E57 "
        "file, or export the scan again",
    )


def _xml_section(data: bytes) -> bytes:
    """The XML section's bytes, the page CRCs left out; the header checked on the way."""
    if len(data) < _HEADER.size:
        raise _refuse(f"only {len(data)} bytes, shorter than an E57 header")
    signature, major, _, length, xml_offset, xml_length, page = _HEADER.unpack_from(data)
    if signature != _SIGNATURE or major != 1 or page != _PAGE:
        raise _refuse("it does not start with an E57 1.x header ('ASTM-E57', 1024-byte pages)")
    if length != len(data) or len(data) % _PAGE:
        raise _refuse(
            f"its header declares {length:,} bytes but the file has {len(data):,} "
            "(truncated upload?)"
        )
    first_page, in_page = divmod(xml_offset, _PAGE)
    start = first_page * _PAGE_DATA + in_page  # logical offset: CRCs do not count
    pages = len(data) // _PAGE
    if in_page >= _PAGE_DATA or start + xml_length > pages * _PAGE_DATA:
        raise _refuse("its XML section lies outside the file")
    last_page = (start + xml_length - 1) // _PAGE_DATA if xml_length else first_page
    logical = b"".join(
        data[index * _PAGE : index * _PAGE + _PAGE_DATA]
        for index in range(first_page, last_page + 1)
    )
    return logical[in_page : in_page + xml_length]


def _declared_points(xml: bytes) -> int:
    """The sum of every compressed vector's ``recordCount``, in plain decimal digits: the
    scans' points, and the line groups some scanners add (an upper bound of the points)."""
    total = 0
    for match in _RECORD_COUNT.finditer(xml):
        value = match.group(2).strip()
        if not value.isdigit():
            raise _refuse(f"a recordCount of {value[:20]!r}")
        total += int(value)
    return total


def _too_large(count: int) -> InvalidShapeError:
    return InvalidShapeError(
        "too_large",
        f"the .e57 file declares {count:,} points, more than the {MAX_PARSED_POINTS:,} "
        "accepted: thin the point cloud before uploading it",
    )


def check_e57_header(data: bytes) -> None:
    """Refuse an E57 file that is truncated, malformed or declares too many points, reading
    only its header and its XML's bytes (nothing is parsed as XML, nothing decoded).

    Parameters
    ----------
    data : bytes
        The whole file.

    Raises
    ------
    InvalidShapeError
        ``unparsable`` or ``too_large``.
    """
    xml = _xml_section(data)
    if _DOCTYPE.search(xml):
        raise _refuse("its XML declares a document type or entities, which E57 never uses")
    count = _declared_points(xml)
    if count > MAX_PARSED_POINTS:
        raise _too_large(count)


def _scan_fields(header: Any, index: int) -> tuple[tuple[str, ...], str]:
    """The coordinate fields of a scan and the name of its invalid-state field."""
    fields = set(header.point_fields)
    if set(_CARTESIAN) <= fields:
        return _CARTESIAN, "cartesianInvalidState"
    if set(_SPHERICAL) <= fields:
        return _SPHERICAL, "sphericalInvalidState"
    raise _refuse(
        f"scan {index + 1} has neither cartesianX/Y/Z nor sphericalRange/Azimuth/Elevation "
        "fields"
    )


def _decode(e57: pye57.E57, header: Any, names: list[str], index: int) -> dict[str, np.ndarray]:
    """Every record of a scan's compressed vector, field by field, read in chunks; refused
    unless exactly the declared count is there."""
    declared = int(header.point_count)
    arrays, buffers = e57.make_buffers(names, max(1, min(_CHUNK, declared)))
    chunks: dict[str, list[np.ndarray]] = {name: [] for name in names}
    total = 0
    reader = header.points.reader(buffers)
    try:
        while total < declared and (read := reader.read()) > 0:
            total += read
            for name in names:  # the buffers are reused by the next read: copy out
                chunks[name].append(arrays[name][:read].copy())
    finally:
        reader.close()
    if total != declared:
        raise _refuse(f"scan {index + 1} declares {declared:,} points but holds {total:,}")
    return {
        name: np.concatenate(parts) if parts else arrays[name][:0]
        for name, parts in chunks.items()
    }


def _scan_points(e57: pye57.E57, index: int) -> np.ndarray:
    """The valid points of scan ``index`` in the file's frame, ``(n, 3)`` float64."""
    header = e57.get_header(index)
    coordinates, invalid = _scan_fields(header, index)
    names = [*coordinates, *([invalid] if invalid in header.point_fields else [])]
    values = _decode(e57, header, names, index)
    points = np.column_stack([values[name].astype(np.float64) for name in coordinates])
    if invalid in values:
        points = points[values[invalid] == 0]
    if coordinates == _SPHERICAL:
        points = convert_spherical_to_cartesian(points)
    if header.has_pose():
        points = e57.to_global(points, header.rotation, header.translation)
    return np.asarray(points, dtype=np.float64).reshape(-1, 3)


def _read_scans(e57: pye57.E57) -> np.ndarray:
    counts = [int(e57.get_header(index).point_count) for index in range(e57.scan_count)]
    if sum(counts) > MAX_PARSED_POINTS:
        raise _too_large(sum(counts))
    clouds = [_scan_points(e57, index) for index in range(e57.scan_count)]
    return np.concatenate(clouds) if clouds else np.zeros((0, 3))


def read_e57(data: bytes) -> np.ndarray:
    """Read the points of every scan of an E57 file, each placed by its pose.

    Parameters
    ----------
    data : bytes
        The whole file.

    Returns
    -------
    (n, 3) float64
        The valid points of all scans, in the file's common frame (metres by the standard).

    Raises
    ------
    InvalidShapeError
        ``unparsable`` or ``too_large``; libE57's own errors on a corrupt file (a bad page
        checksum, a malformed XML) are turned into ``unparsable`` by the loader.
    """
    check_e57_header(data)
    # libE57 opens files by path only; the directory and the copy live for the read alone.
    with tempfile.TemporaryDirectory(prefix="shapesearch-e57-") as folder:
        path = Path(folder) / "upload.e57"
        path.write_bytes(data)
        with pye57.E57(str(path)) as e57:
            return _read_scans(e57)
