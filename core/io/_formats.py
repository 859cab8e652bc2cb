"""Which format a file is in: by its extension first, by its first bytes otherwise.

The extension wins because it is what the user chose and because several formats (the text
point formats, OBJ) have no magic number at all. The first bytes are only consulted when there
is no file name or its extension is not one we read.
"""

from __future__ import annotations

import os
import re

from core.errors import InvalidShapeError

__all__ = [
    "CAD_FORMATS",
    "CRASHING_FORMATS",
    "EXPANDING_FORMATS",
    "FILE_EXTENSIONS",
    "MESH_FORMATS",
    "POINT_FORMATS",
    "SCAN_FORMATS",
    "SUPPORTED_FORMATS",
    "TEXT_POINT_FORMATS",
    "detect_format",
]

#: Formats read as plain text columns ``x y z [extra ...]``.
TEXT_POINT_FORMATS: tuple[str, ...] = ("xyz", "txt", "csv", "pts")
#: Binary formats of laser scanners: ASTM E57 (pye57), ASPRS LAS and its compressed LAZ (laspy).
SCAN_FORMATS: tuple[str, ...] = ("e57", "las", "laz")
#: Formats that hold points only.
POINT_FORMATS: tuple[str, ...] = (*TEXT_POINT_FORMATS, "pcd", "npy", *SCAN_FORMATS)
#: Formats read through trimesh. PLY is here although a PLY without faces is a point cloud;
#: glTF as a text ``.gltf`` only with its buffers embedded (data URIs); 3MF is a zip archive.
MESH_FORMATS: tuple[str, ...] = ("stl", "obj", "off", "ply", "glb", "gltf", "3mf")
#: CAD formats, tessellated through OpenCascade (optional extra); stp/igs are aliases.
CAD_FORMATS: tuple[str, ...] = ("step", "iges")
_CAD_ALIASES = {"stp": "step", "igs": "iges"}
#: Every format ``load_points`` reads, named by its usual extension.
SUPPORTED_FORMATS: tuple[str, ...] = (*MESH_FORMATS, *POINT_FORMATS, *CAD_FORMATS)
#: Formats whose geometry can be far larger than the file: a glTF scene instances meshes, a
#: 3MF is deflated XML that may also instance them, LAZ compresses points arithmetically and
#: E57 bit-packs them (a constant field takes no bits).
#: Their size says nothing about the memory parsing takes, so they are parsed in a sandbox.
#: (LZF, in PCD files, expands at most 88-fold: a small PCD stays small.)
EXPANDING_FORMATS: tuple[str, ...] = ("glb", "gltf", "3mf", "laz", "e57")
#: Formats read by native code that a malformed file can crash outright, which no exception
#: handler sees: OpenCascade's STEP reader dereferences a null handle when an entity a vector
#: points to has an unknown type (27 of 300 mutated STEP files ended their process with a
#: segmentation fault), and lazrs aborts its process when an allocation a corrupt LAZ chunk
#: table asks for (48 GB in one mutant) is refused. Like the expanding formats, they are
#: parsed in a sandbox only (``bench/fuzz_loader.py``).
CRASHING_FORMATS: tuple[str, ...] = (*CAD_FORMATS, "laz")
#: Every file name extension that names a format (compared case-insensitively).
FILE_EXTENSIONS: tuple[str, ...] = (*SUPPORTED_FORMATS, *_CAD_ALIASES)

_NPY_MAGIC = b"\x93NUMPY"
_GLB_MAGIC = b"glTF"
_E57_MAGIC = b"ASTM-E57"
_LAS_MAGIC = b"LASF"
# Byte of a LAS header holding the point format; LAZ sets bit 7 (or, in old files, bit 6).
_LAS_POINT_FORMAT_BYTE = 104
# Keywords that open a PCD header (a comment line, then VERSION, FIELDS, ... in this order).
_PCD_HEADER = re.compile(rb"^\s*(#\s*\.PCD|VERSION\s|FIELDS\s)")
# Three numbers at the start of a line, separated by whitespace, commas or semicolons.
_NUMERIC_ROW = re.compile(
    rb"^\s*[-+]?(\d|\.\d)[^\s,;]*[\s,;]+[-+]?(\d|\.\d)[^\s,;]*[\s,;]+[-+]?(\d|\.\d)", re.M
)


def _extension(filename: str | None) -> str | None:
    """Lower-case extension without the dot, or None when there is none."""
    if not filename:
        return None
    ext = os.path.splitext(filename.strip())[1].lower().lstrip(".")
    return ext or None


def _sniff(head: bytes) -> str | None:
    """Guess the format from the first bytes of a file; None when nothing matches.

    Parameters
    ----------
    head : bytes
        The first few hundred bytes of the file (more is fine).
    """
    if head.startswith(_NPY_MAGIC):
        return "npy"
    if head.startswith(_GLB_MAGIC):
        return "glb"
    if head.startswith(_E57_MAGIC):
        return "e57"
    if head.startswith(_LAS_MAGIC) and len(head) > _LAS_POINT_FORMAT_BYTE:
        return "laz" if head[_LAS_POINT_FORMAT_BYTE] & 0xC0 else "las"
    if head.lstrip().startswith(b"ISO-10303-21;"):
        return "step"
    stripped = head.lstrip()
    if re.match(rb"ply\s", stripped):
        return "ply"
    if _PCD_HEADER.match(head):
        return "pcd"
    # ``solid`` opens an ASCII STL; binary STL headers often start with it too, and the STL
    # reader tells the two apart by size, so "stl" is right either way.
    if stripped[:5].lower() == b"solid":
        return "stl"
    if re.match(rb"[CN]?OFF\b", stripped):
        return "off"
    if re.search(rb"^\s*(v|f)\s+[-+\d.]", head, re.M) and not _NUMERIC_ROW.match(stripped):
        return "obj"
    if b"\x00" not in head and _NUMERIC_ROW.search(head):
        # Plain numeric columns: read as the generic text point format.
        return "xyz"
    return None


def _unknown(filename: str | None) -> InvalidShapeError:
    what = f"'{filename}'" if filename else "this file"
    return InvalidShapeError(
        "unknown_format",
        f"could not tell the format of {what}: upload one of "
        f"{', '.join('.' + f for f in SUPPORTED_FORMATS)} (the file name's extension "
        "tells the format)",
    )


def detect_format(filename: str | None, head: bytes) -> str:
    """Name the format of a file.

    Parameters
    ----------
    filename : str or None
        Original file name; its extension decides, case-insensitively (``part.STL``).
    head : bytes
        The first bytes of the file, used when the extension is missing or not supported.

    Returns
    -------
    str
        One of ``SUPPORTED_FORMATS``.

    Raises
    ------
    InvalidShapeError
        ``reason="unknown_format"``, listing the supported formats.
    """
    ext = _extension(filename)
    ext = _CAD_ALIASES.get(ext or "", ext)
    if ext in SUPPORTED_FORMATS:
        return ext
    sniffed = _sniff(bytes(head[:4096]))
    if sniffed is None:
        raise _unknown(filename)
    return sniffed
