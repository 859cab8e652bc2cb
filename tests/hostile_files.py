"""Hostile shape files, made in code (no committed blobs), shared by tests and bench.

``glb_instancing_bomb(instances)``
    A small GLB whose scene instances one mesh (an icosphere of 2,562 vertices) ``instances``
    times: 3,000 instances make a 0.2 MB file that expands to 7.7 million vertices, 20,000
    a 1.4 MB file that expands to 51 million.
``stl_triangle_bomb(size)``
    A binary STL of ``size`` bytes (60 MB by default) whose header declares 3.2 billion
    triangles: 160 GB of records it does not have.
``ply_vertex_bomb()``
    A tiny binary PLY whose header declares 10^9 vertices.
``pcd_lzf_bomb(points, extra)``
    A PCD ``binary_compressed`` file of ``points`` records of x, y, z and ``extra`` float
    padding values: 5 million records of 812 bytes declare 4 GB uncompressed, behind a
    real 11 KB LZF block.
``scan_variants()``
    Truncated and lying E57, LAS, LAZ and PCD files made from a valid scan of a sphere.
``obj_short_vertex()``
    An OBJ one of whose ``v`` lines holds two numbers (trimesh reads two columns).
``step_part()``, ``iges_part()``, ``break_step(data)``, ``step_reader_crash()``
    A small STEP part and the same as IGES; a STEP file with one ``VECTOR`` entity renamed,
    on which OpenCascade's reader ends its process with a segmentation fault, and the part
    so broken (only where OpenCascade imports; found by ``bench/fuzz_loader.py``).
``iges_reader_hang()``
    ``iges_part()`` with two fields overwritten in place, on which OpenCascade's reader
    never returns (found by ``bench/fuzz_loader.py``).
"""

from __future__ import annotations

import base64
import json
import struct
from collections.abc import Callable
from typing import Any

import lzf
import numpy as np
import trimesh

from tests.scan_files import (
    e57_file,
    e57_with_record_count,
    las_file,
    las_with_point_count,
    pcd_compressed_file,
)
from tests.shapes import fibonacci_sphere_points

__all__ = [
    "HOSTILE_FILES",
    "break_step",
    "glb_instancing_bomb",
    "gltf_instancing_bomb",
    "iges_part",
    "iges_reader_hang",
    "obj_short_vertex",
    "opencascade_imports",
    "pcd_lzf_bomb",
    "ply_vertex_bomb",
    "scan_variants",
    "step_part",
    "step_reader_crash",
    "stl_triangle_bomb",
]


def _pad(chunk: bytes, fill: bytes) -> bytes:
    return chunk + fill * (-len(chunk) % 4)


def glb_instancing_bomb(instances: int) -> bytes:
    """A GLB: one icosphere mesh, ``instances`` nodes that each place it (a flat scene)."""
    sphere = trimesh.creation.icosphere(subdivisions=4)
    vertices = np.asarray(sphere.vertices, np.float32)
    faces = np.asarray(sphere.faces, np.uint32)
    binary = _pad(vertices.tobytes() + faces.tobytes(), b"\x00")
    document = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(binary)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": vertices.nbytes},
            {"buffer": 0, "byteOffset": vertices.nbytes, "byteLength": faces.nbytes},
        ],
        "accessors": [
            {
                "bufferView": 0, "componentType": 5126, "count": len(vertices), "type": "VEC3",
                "min": vertices.min(axis=0).tolist(), "max": vertices.max(axis=0).tolist(),
            },
            {"bufferView": 1, "componentType": 5125, "count": faces.size, "type": "SCALAR"},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": [{"mesh": 0, "translation": [3.0 * i, 0.0, 0.0]} for i in range(instances)],
        "scenes": [{"nodes": list(range(instances))}],
        "scene": 0,
    }
    text = _pad(json.dumps(document, separators=(",", ":")).encode(), b" ")
    chunks = struct.pack("<I4s", len(text), b"JSON") + text
    chunks += struct.pack("<I4s", len(binary), b"BIN\x00") + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


def gltf_instancing_bomb(instances: int) -> bytes:
    """The same scene as a text ``.gltf``, its buffer embedded as a base64 data URI."""
    glb = glb_instancing_bomb(instances)
    length = struct.unpack_from("<I", glb, 12)[0]
    document = json.loads(glb[20 : 20 + length])
    binary = glb[20 + length + 8 :]
    document["buffers"] = [{"byteLength": len(binary), "uri": "data:application/octet-stream;"
                            "base64," + base64.b64encode(binary).decode()}]
    return json.dumps(document).encode()


def stl_triangle_bomb(size: int = 60 * 1024 * 1024, triangles: int = 3_200_000_000) -> bytes:
    """``size`` bytes of binary STL (random records) declaring ``triangles`` triangles."""
    header = b"hostile".ljust(80, b" ") + struct.pack("<I", triangles)
    body = np.random.default_rng(0).integers(0, 256, size - len(header), dtype=np.uint8)
    return header + body.tobytes()


def ply_vertex_bomb(vertices: int = 10**9) -> bytes:
    """A binary PLY declaring ``vertices`` vertices, followed by three of them."""
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n"
        "end_header\n"
    ).encode()
    return header + np.eye(3, dtype=np.float32).tobytes()


def pcd_lzf_bomb(points: int = 5_000_000, extra: int = 200) -> bytes:
    """A PCD whose LZF block declares ``points * (12 + 4 * extra)`` bytes uncompressed
    (consistent with its header, so only the size gives it away)."""
    header = (
        "VERSION 0.7\nFIELDS x y z pad\nSIZE 4 4 4 4\nTYPE F F F F\n"
        f"COUNT 1 1 1 {extra}\nWIDTH {points}\nHEIGHT 1\nPOINTS {points}\n"
        "DATA binary_compressed\n"
    ).encode()
    block = lzf.compress(bytes(1024 * 1024))
    return header + struct.pack("<II", len(block), points * (12 + 4 * extra)) + block


def _scan_points() -> np.ndarray:
    return fibonacci_sphere_points(2000) * 25.0


def _e57() -> bytes:
    return e57_file(_scan_points())


def _las(compressed: bool) -> bytes:
    return las_file(_scan_points(), compressed)


def _pcd_ratio_lie() -> bytes:
    """4 million x, y, z points (48 MB, as declared) from a 35 KB LZF block."""
    data = pcd_compressed_file(_scan_points())
    data = data.replace(b"WIDTH 2000", b"WIDTH 4000000").replace(b"POINTS 2000", b"POINTS 4000000")
    start = data.index(b"binary_compressed\n") + len(b"binary_compressed\n")
    compressed, _ = struct.unpack_from("<II", data, start)
    return data[:start] + struct.pack("<II", compressed, 4_000_000 * 16) + data[start + 8 :]


def scan_variants() -> dict[str, tuple[str, Callable[[], bytes], int, str]]:
    """Hostile scanner files, as ``HOSTILE_FILES`` entries."""
    return {
        "e57-truncated": ("cut.e57", lambda: _e57()[:-3000], 422, "unparsable"),
        "e57-4e9-points": (
            "lying.e57", lambda: e57_with_record_count(_e57(), 4_000_000_000), 413, "too_large"
        ),
        "e57-4e6-points-2e3-held": (
            "lying.e57", lambda: e57_with_record_count(_e57(), 4_000_000), 422, "unparsable"
        ),
        "las-truncated": ("cut.las", lambda: _las(False)[:-100], 422, "unparsable"),
        "las-4e6-points-2e3-held": (
            "lying.las", lambda: las_with_point_count(_las(False), 4_000_000), 422, "unparsable"
        ),
        "laz-truncated": ("cut.laz", lambda: _las(True)[:-2000], 422, "unparsable"),
        "laz-4e9-points": (
            "bomb.laz", lambda: las_with_point_count(_las(True), 4_000_000_000), 413, "too_large"
        ),
        "laz-4e6-points-2e3-held": (
            "lying.laz", lambda: las_with_point_count(_las(True), 4_000_000), 422, "unparsable"
        ),
        "pcd-lzf-truncated": (
            "cut.pcd", lambda: pcd_compressed_file(_scan_points())[:-500], 422, "unparsable"
        ),
        "pcd-lzf-4gb-declared": ("bomb.pcd", pcd_lzf_bomb, 413, "too_large"),
        "pcd-lzf-beyond-88x": ("lying.pcd", _pcd_ratio_lie, 422, "unparsable"),
    }


def obj_short_vertex() -> bytes:
    """300 vertices of which the sixth has two coordinates, and 97 triangles."""
    rng = np.random.default_rng(0)
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in rng.random((300, 3))]
    lines[5] = "v 0.5 0.25"
    lines += [f"f {i + 1} {i + 2} {i + 3}" for i in range(0, 290, 3)]
    return ("\n".join(lines) + "\n").encode()


def break_step(data: bytes) -> bytes:
    """A STEP file with its first ``VECTOR`` entity given an unknown type."""
    return data.replace(b"= VECTOR(", b"= BOGUS_ENTITY(", 1)


def step_reader_crash() -> bytes:
    """``step_part()`` broken by ``break_step``."""
    return break_step(step_part())


def step_part() -> bytes:
    """A valid STEP file: a 10 x 8 x 4 box with a hole (needs OpenCascade)."""
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    writer = STEPControl_Writer()
    writer.Transfer(_box_with_hole(), STEPControl_AsIs)
    return _written(writer, "part.step")


def iges_part() -> bytes:
    """``step_part()``'s box as IGES (needs OpenCascade)."""
    from OCP.IGESControl import IGESControl_Writer

    writer = IGESControl_Writer("MM", 0)
    writer.AddShape(_box_with_hole())
    writer.ComputeModel()
    return _written(writer, "part.iges")


def iges_reader_hang() -> bytes:
    """``iges_part()`` with the global section's file name run into the next field (its
    last byte and the delimiter become a float's bytes) and one arc's coordinate holding a
    NaN's bytes, both in place (IGES records are fixed columns): OpenCascade's reader spins
    on it for more than 10 minutes. Either change alone is read."""
    part = iges_part()
    hanging = part.replace(b"13HFilename.iges,  ", b"13HFilename.ige\x00\x00\x80\x7f", 1)
    hanging = hanging.replace(b"-3.920107719E-15", b"-3.920\x00\x00\xc0\x7f19E-15", 1)
    # Both fields are where OpenCascade's IGES writer puts them for this part; a writer
    # that changed them must fail here, not leave a test posting a readable file.
    assert sum(a != b for a, b in zip(part, hanging, strict=True)) == 8
    return hanging


def _box_with_hole() -> Any:
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder

    return BRepAlgoAPI_Cut(BRepPrimAPI_MakeBox(10.0, 8.0, 4.0).Shape(),
                           BRepPrimAPI_MakeCylinder(2.0, 4.0).Shape()).Shape()


def _written(writer: Any, name: str) -> bytes:
    """What an OpenCascade writer (which writes to paths only) writes, as bytes."""
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / name
        writer.Write(str(path))
        return path.read_bytes()


def opencascade_imports() -> bool:
    """Whether OpenCascade (the ``cad`` extra) imports here."""
    try:
        import OCP.STEPControl  # noqa: F401
    except ImportError:
        return False
    return True


#: name -> (file name, bytes maker, expected status, expected reason)
HOSTILE_FILES = {
    "glb-20000-instances": ("bomb.glb", lambda: glb_instancing_bomb(20_000), 413, "too_large"),
    "glb-3000-instances": ("bomb.glb", lambda: glb_instancing_bomb(3_000), 413, "too_large"),
    "gltf-20000-instances": ("bomb.gltf", lambda: gltf_instancing_bomb(20_000), 413,
                             "too_large"),
    "stl-3.2e9-triangles": ("bomb.stl", stl_triangle_bomb, 422, "unparsable"),
    "ply-1e9-vertices": ("bomb.ply", ply_vertex_bomb, 413, "too_large"),
    "obj-short-vertex-line": ("short.obj", obj_short_vertex, 422, "unparsable"),
    **scan_variants(),
    **({"step-reader-crash": ("crash.step", step_reader_crash, 422, "unparsable")}
       if opencascade_imports() else {}),
}
