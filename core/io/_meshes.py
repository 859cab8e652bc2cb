"""Reading ``.stl .obj .off .ply .glb .gltf .3mf`` through trimesh.

trimesh does the parsing (with ``process=False``: merging vertices or fixing normals would only
cost time, since the mesh is sampled anyway). Around it this module

* provides cheap structural checks (STL size, PLY header; run by ``core.io._headers`` before
  this reader) so that empty or truncated files get a precise reason instead of whatever
  trimesh happens to do with them;
* never lets an OBJ or glTF read other files (no resolver: ``mtllib`` and external buffers
  are ignored; the geometry is all we need and an upload must not reach the server's disk);
* flattens a Scene into one set of vertices and triangles, with each node's transform applied.
"""

from __future__ import annotations

import io
import re
import struct
from dataclasses import dataclass

import numpy as np
import trimesh

from core.errors import InvalidShapeError
from core.io._validate import MAX_PARSED_POINTS

__all__ = ["RawGeometry", "check_ply_header", "check_stl_header", "read_mesh"]

_STL_HEADER = 80
_STL_RECORD = 50
_PLY_BINARY_VERTEX = 12
_PLY_ASCII_VERTEX = 6
# Record keywords of OBJ files; a file made only of these (and comments) is valid.
_OBJ_KEYWORDS = frozenset(
    {"v", "vt", "vn", "vp", "f", "l", "p", "o", "g", "s", "mg", "usemtl", "mtllib"}
    | {"curv", "curv2", "surf", "cstype", "deg", "parm", "end"}
)


@dataclass(frozen=True)
class RawGeometry:
    """Vertices and triangles as read from a file.

    Attributes
    ----------
    vertices : (v, 3) float64
    faces : (f, 3) int64
        Valid indices into ``vertices``; ``f == 0`` for a point cloud (a PLY without faces).
    """

    vertices: np.ndarray
    faces: np.ndarray


def _unparsable(fmt: str, detail: str) -> InvalidShapeError:
    return InvalidShapeError(
        "unparsable",
        f"could not read this .{fmt} file ({detail}): check that it is a complete, valid "
        f".{fmt} file, or export the part again",
    )


def _empty(fmt: str, what: str) -> InvalidShapeError:
    return InvalidShapeError(
        "empty_file",
        f"this .{fmt} file contains no {what}: upload a file that holds the part's mesh or "
        "point cloud",
    )


def check_stl_header(data: bytes) -> None:
    """Refuse empty or truncated STL files before trimesh guesses what they are.

    A binary STL is an 80-byte header, a uint32 triangle count and 50 bytes per triangle, so
    its size is known; an ASCII STL starts with ``solid`` (binary headers may too, which is why
    the size is checked first).
    """
    count = struct.unpack("<I", data[80:84])[0] if len(data) >= 84 else None
    if count is not None and len(data) == _STL_HEADER + 4 + _STL_RECORD * count:
        if count == 0:
            raise _empty("stl", "triangles (its triangle count is 0)")
        return
    # ASCII STL is text: a NUL byte means a binary file whose header happens to say "solid".
    if data.lstrip()[:5].lower() == b"solid" and b"\x00" not in data[:1024]:
        if not re.search(rb"\bvertex\b", data):
            raise _empty("stl", "triangles (no 'facet' / 'vertex' records)")
        return
    if count is None:
        raise _unparsable("stl", f"only {len(data)} bytes, shorter than a binary STL header")
    expected = _STL_HEADER + 4 + _STL_RECORD * count
    if len(data) < expected:
        raise _unparsable(
            "stl",
            f"binary STL declares {count:,} triangles ({expected:,} bytes) but has only "
            f"{len(data):,} bytes: the file is truncated",
        )


def check_ply_header(data: bytes) -> None:
    """Refuse PLY files whose header is missing, has no vertices, or declares too many."""
    end = data.find(b"end_header")
    if end < 0:
        raise _unparsable("ply", "no 'end_header' line")
    header = data[:end].decode("ascii", errors="replace")
    match = re.search(r"^\s*element\s+vertex\s+(\d+)", header, re.M)
    if match is None or int(match.group(1)) == 0:
        raise _empty("ply", "vertices (its header declares none)")
    declared = int(match.group(1))
    if declared > MAX_PARSED_POINTS:
        raise InvalidShapeError(
            "too_large",
            f"the PLY file declares {declared:,} vertices, more than the "
            f"{MAX_PARSED_POINTS:,} accepted: simplify the mesh or thin the cloud first",
        )
    # Each vertex takes at least three float32 (binary) or "0 0 0\n" (ASCII).
    binary = re.search(r"^\s*format\s+binary", header, re.M) is not None
    needed = declared * (_PLY_BINARY_VERTEX if binary else _PLY_ASCII_VERTEX)
    body = len(data) - end - len(b"end_header")
    if needed > body:
        raise _unparsable(
            "ply",
            f"its header declares {declared:,} vertices (at least {needed:,} bytes) but only "
            f"{body:,} bytes follow: the file is truncated",
        )


def _no_geometry(fmt: str, data: bytes) -> InvalidShapeError:
    """Reason for a file trimesh read without finding any geometry."""
    if fmt == "obj":
        keywords = {
            line.split()[0]
            for line in data.decode("utf-8", errors="replace").splitlines()
            if line.strip() and not line.lstrip().startswith("#")
        }
        if not keywords <= _OBJ_KEYWORDS:
            return _unparsable("obj", "lines that are not OBJ records")
    if fmt == "stl":
        return _unparsable("stl", "no triangles could be read")
    return _empty(fmt, "vertices")


def _load_scene(data: bytes, fmt: str) -> trimesh.Scene:
    try:
        return trimesh.load_scene(io.BytesIO(data), file_type=fmt, process=False)
    except MemoryError:  # the file is too large for the memory it may take, not unreadable
        raise
    except Exception as exc:  # trimesh raises many types for bad input; all mean "bad file"
        raise _unparsable(fmt, f"{type(exc).__name__}: {str(exc)[:120]}") from exc


def _flatten(scene: trimesh.Scene, fmt: str) -> RawGeometry | None:
    """All triangles of the scene in world coordinates; the vertices only if it has none.

    Returns None when the scene holds neither triangles nor points (paths are ignored).
    Vertices that are not three coordinates each are ``unparsable``: trimesh reshapes an OBJ
    whose ``v`` lines disagree in length (one line of two numbers among thousands of three)
    into two columns rather than refusing it.
    """
    meshes, clouds = [], []
    for geometry in scene.dump():
        if isinstance(geometry, trimesh.Trimesh | trimesh.PointCloud):
            shape = np.shape(geometry.vertices)
            if len(shape) != 2 or (shape[0] and shape[1] != 3):
                raise _unparsable(
                    fmt, f"vertices that are not three coordinates each, read as {shape}"
                )
        if isinstance(geometry, trimesh.Trimesh) and len(geometry.faces):
            meshes.append((np.asarray(geometry.vertices), np.asarray(geometry.faces)))
        elif isinstance(geometry, trimesh.Trimesh | trimesh.PointCloud) and len(geometry.vertices):
            clouds.append(np.asarray(geometry.vertices))
    if meshes:
        offsets = np.cumsum([0] + [len(v) for v, _ in meshes[:-1]])
        vertices = np.concatenate([v for v, _ in meshes])
        faces = np.concatenate(
            [f.reshape(-1, 3) + o for (_, f), o in zip(meshes, offsets, strict=True)]
        )
        return RawGeometry(np.asarray(vertices, np.float64), np.asarray(faces, np.int64))
    if clouds:
        return RawGeometry(np.concatenate(clouds).astype(np.float64), np.zeros((0, 3), np.int64))
    return None


def _drop_bad_faces(geometry: RawGeometry) -> RawGeometry:
    """Remove triangles that index vertices outside the file (a corrupt face list)."""
    faces = geometry.faces
    valid = ((faces >= 0) & (faces < len(geometry.vertices))).all(axis=1)
    if valid.all():
        return geometry
    return RawGeometry(geometry.vertices, faces[valid])


def read_mesh(data: bytes, fmt: str) -> RawGeometry:
    """Read a mesh (or a PLY point cloud) with trimesh.

    Parameters
    ----------
    data : bytes
        The whole file.
    fmt : str
        One of ``MESH_FORMATS``.

    Returns
    -------
    RawGeometry
        ``faces`` is empty when the file holds points only.

    Raises
    ------
    InvalidShapeError
        ``empty_file``, ``unparsable``, ``too_large``.
    """
    geometry = _flatten(_load_scene(data, fmt), fmt)
    if geometry is None:
        raise _no_geometry(fmt, data)
    if len(geometry.vertices) > MAX_PARSED_POINTS:
        raise InvalidShapeError(
            "too_large",
            f"the mesh has {len(geometry.vertices):,} vertices, more than the "
            f"{MAX_PARSED_POINTS:,} accepted: simplify the mesh before uploading it",
        )
    return _drop_bad_faces(geometry)
