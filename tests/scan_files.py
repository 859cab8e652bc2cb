"""Scanner files made in code (no committed blobs), for tests and bench: E57 through pye57,
LAS and LAZ through laspy, PCD ``binary_compressed`` through LZF.

``e57_file(points)``, ``las_file(points, compressed)``, ``pcd_compressed_file(points)``
    Valid files holding ``points``. E57 stores float32 coordinates (pye57 writes single
    precision), LAS/LAZ integers scaled by 1e-6, PCD float32.
``e57_with_record_count(data, count)``
    The same E57 file with its scan's ``recordCount`` changed to ``count`` and every page
    checksum recomputed, so that only the count lies.
``las_with_point_count(data, count)``
    A LAS 1.2 or LAZ file whose header declares ``count`` points.
"""

from __future__ import annotations

import io
import re
import struct
import tempfile
from pathlib import Path

import laspy
import lzf
import numpy as np
import pye57

__all__ = [
    "e57_file",
    "e57_with_record_count",
    "las_file",
    "las_with_point_count",
    "pcd_compressed_file",
]

_E57_PAGE = 1024
_E57_PAGE_DATA = _E57_PAGE - 4
_LAS_COUNT_AT = 107  # the 32-bit point count of a LAS 1.0-1.3 header


def e57_file(points: np.ndarray) -> bytes:
    """One scan of ``points`` : (n, 3) float, at the identity pose."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scan.e57"
        with pye57.E57(str(path), mode="w") as e57:
            e57.write_scan_raw({
                "cartesianX": points[:, 0], "cartesianY": points[:, 1],
                "cartesianZ": points[:, 2],
            })
        return path.read_bytes()


def _crc32c(data: bytes) -> int:
    """CRC-32C (Castagnoli), bit by bit: E57 pages are checked with it."""
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ (0x82F63B78 & -(crc & 1))
    return crc ^ 0xFFFFFFFF


def e57_with_record_count(data: bytes, count: int) -> bytes:
    """``data`` (from ``e57_file``) declaring ``count`` points; the XML keeps its length
    (the longer number eats into the indentation after it) and the pages get new CRCs."""
    logical = bytearray(
        b"".join(data[i : i + _E57_PAGE_DATA] for i in range(0, len(data), _E57_PAGE))
    )
    match = re.search(rb'recordCount="\d+">\s+', logical)
    assert match is not None
    replacement = b'recordCount="%d">\n' % count
    assert len(replacement) <= len(match.group(0)), "not enough indentation to absorb it"
    logical[match.start() : match.end()] = replacement.ljust(len(match.group(0)), b" ")
    pages = []
    for start in range(0, len(logical), _E57_PAGE_DATA):
        page = bytes(logical[start : start + _E57_PAGE_DATA])
        pages.append(page + struct.pack(">I", _crc32c(page)))
    return b"".join(pages)


def las_file(points: np.ndarray, compressed: bool) -> bytes:
    """A LAS 1.2 (point format 0) or LAZ file of ``points`` : (n, 3) float, 1e-6 units."""
    header = laspy.LasHeader(point_format=0, version="1.2")
    header.offsets = points.min(axis=0)
    header.scales = np.full(3, 1e-6)
    las = laspy.LasData(header)
    las.x, las.y, las.z = points[:, 0], points[:, 1], points[:, 2]
    stream = io.BytesIO()
    backend = laspy.LazBackend.Lazrs if compressed else None
    las.write(stream, do_compress=compressed, laz_backend=backend)
    return stream.getvalue()


def las_with_point_count(data: bytes, count: int) -> bytes:
    """``data`` (from ``las_file``) whose header declares ``count`` points (< 2**32)."""
    return data[:_LAS_COUNT_AT] + struct.pack("<I", count) + data[_LAS_COUNT_AT + 4 :]


def pcd_compressed_file(points: np.ndarray) -> bytes:
    """A PCD v0.7 ``DATA binary_compressed`` file: float32 x y z and a uint32 rgb, the
    fields one after the other, LZF-compressed as PCL writes them."""
    n = len(points)
    columns = [np.ascontiguousarray(points[:, axis], dtype="<f4") for axis in range(3)]
    columns.append(np.full(n, 0x00FF8000, dtype="<u4"))
    raw = b"".join(column.tobytes() for column in columns)
    # LZF may not shrink float noise: allow it to grow a little rather than fail.
    compressed = lzf.compress(raw, len(raw) + len(raw) // 16 + 64)
    header = (
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\n"
        "SIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\n"
        f"WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary_compressed\n"
    ).encode()
    return header + struct.pack("<II", len(compressed), len(raw)) + compressed
